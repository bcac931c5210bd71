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
// elastic bodies only -> smooth_solver. A coupled scene (bodies, contact nodes and
// coupling.interface_nodes) runs its contact process (`--process NAME`, outputs in
// OUT/NAME) and smooth_solver, the coordinator, last, both with the ipc endpoint. Throws
// InputError for a scene with neither, or bodies and contact nodes not tied together.
std::vector<ProcessPlan> PlanProcesses(const ScenarioFile& file, const std::vector<std::string>& arguments);

// Starts every process, waits for all, and returns the last process's exit code if it failed
// (the coordinator of a coupled run), else the first non-zero one (a process killed by a
// signal counts as a numerical failure, 3), or 0.
int RunProcesses(const std::string& bin_dir, const std::vector<ProcessPlan>& plan);

}  // namespace cosim::interface
