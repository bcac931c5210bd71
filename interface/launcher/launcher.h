#pragma once
// The launcher behind `scripts/cosim run`: decides from the scenario which processes a run
// needs, starts them with the same command line, waits, and passes their exit status on.
#include <string>
#include <vector>

#include "interface/scenario/scenario_file.h"

namespace cosim::interface {

struct ProcessPlan {
  std::string program;                 // executable name, next to cosim_launch
  std::vector<std::string> arguments;  // after the program name
};

// Single-solver scenes run one process: contact nodes only -> nonsmooth_solver; rigid or
// elastic bodies only -> smooth_solver. Throws InputError for a scene with neither.
std::vector<ProcessPlan> PlanProcesses(const ScenarioFile& file, const std::vector<std::string>& arguments);

// Starts every process, waits for all, and returns the first non-zero exit code (a process
// killed by a signal counts as a numerical failure, 3), or 0.
int RunProcesses(const std::string& bin_dir, const std::vector<ProcessPlan>& plan);

}  // namespace cosim::interface
