#pragma once
// The run contract shared by every solver executable: command line, scenario loading,
// the time loop, output decimation, timing, exit codes and the summary of a failed run.
// A solver supplies a Simulation; RunProgram does the rest.
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "interface/base/errors.h"
#include "interface/run/run_output.h"
#include "interface/scenario/scenario_file.h"
#include "interface/visual/visual_frame.h"

namespace cosim::interface {

struct CommandLine {
  std::string scenario;           // path of the scenario file
  std::string out;                // output folder; empty: runs/<scenario name>
  std::vector<std::string> sets;  // --set FIELD.PATH=VALUE, in order
  std::string process;            // --process NAME: serve as that contact process of a coupled run
};

// Parses `SCENARIO [--out DIR] [--set PATH=VALUE]... [--process NAME]`; throws InputError.
CommandLine ParseCommandLine(const std::vector<std::string>& arguments);
std::string Usage(const std::string& program);

// The time span of a scenario, validated: start_time < end_time, step > 0, at most 2e9 steps,
// and a step that the times' resolution can represent.
struct TimeSpan {
  double start = 0.0;
  double end = 0.0;
  double step = 0.0;
  long long steps = 0;  // the last step is shortened to end exactly at `end`
  double TimeAt(long long k) const;
};
TimeSpan ValidateTimeSpan(const ScenarioFile& file);

class Simulation {
 public:
  virtual ~Simulation() = default;
  virtual std::vector<std::string> ProbeNames() const = 0;
  // Current probe values, in ProbeNames() order.
  virtual void Probe(std::vector<double>* values) const = 0;
  // Advances the state from t to t + h. Throws NumericalError (exit 3) or PeerError (exit 4)
  // leaving the last accepted state in place.
  virtual void Step(double t, double h) = 0;
  // Once before the first row, with the same failure contract as Step: a coupled process's
  // handshake, which may set the state the first row shows (a settled start's contact nodes).
  virtual void Start() {}
  // Statistics and the settings used (defaults filled in).
  virtual void FillSummary(run::RunSummary* summary) const = 0;
  // The run is over (normally, or with `code` and `reason`): tell the peers. Errors here are
  // the peers' problem and are not reported.
  virtual void Finish(ExitCode /*code*/, const std::string& /*reason*/) {}
  // Files of its own in the output folder (e.g. the coupling convergence log): opened once the
  // folder is locked for the run, before the first step, written as the run goes, and closed
  // at its end, failed or not (EndOutput throws an Error for a failed write).
  virtual void BeginOutput(const std::string& /*folder*/) {}
  virtual void EndOutput() {}
  // The scene at the state the probes read, for the visual output (output.visual).
  virtual void Visual(VisualFrame* /*frame*/) const {}
};

using SimulationFactory = std::function<std::unique_ptr<Simulation>(const ScenarioFile&, const CommandLine&)>;

// For a run that ends before its first step (bad input, exit 2; an endpoint that cannot be
// bound, exit 4): if the command line named an output folder, writes summary.json (status
// failed, the exit code, the reason) and an empty history.csv there, so that a study records
// the failure. Best effort: a folder that cannot be written (or that another run holds) is
// itself the error already reported.
void WriteFailureSummary(const std::string& program, const CommandLine& cli, ExitCode code, const std::string& reason);

// The scenario's name: its `name`, else its file's stem if that is a valid name, else "run";
// the default output folder is runs/<name>.
std::string ScenarioName(const ScenarioFile& file);
std::string DefaultOutFolder(const ScenarioFile& file);

// main() of a solver executable. Returns the process exit code. With `--process NAME` (a
// coupled run's contact process) the scene is loaded as `process_view`.
int RunProgram(const std::string& program, int argc, char** argv, const SimulationFactory& factory,
               ScenarioView process_view = ScenarioView::kWhole);

// SIGTERM and SIGINT (the launcher stopping a run whose other process failed, or a user's ^C)
// set a flag that RunProgram's time loop and the coupling channel's waits check: the run then
// ends as a peer failure (exit 4) with its outputs up to the last accepted step.
void InstallTerminationHandler();
bool TerminationRequested();

}  // namespace cosim::interface
