// cosim_launch: `scripts/cosim run SCENARIO [--out DIR] [--set P=V]...` ends here. It reads
// the scenario, decides which processes the run needs, starts them with the same command
// line and passes their exit status on. A single-solver run's process validates the scenario
// itself and writes the summary of a bad-input failure.
#include <unistd.h>

#include <filesystem>
#include <iostream>

#include "interface/launcher/launcher.h"
#include "interface/run/run_driver.h"

int main(int argc, char** argv) {
  using namespace cosim;
  std::vector<std::string> arguments(argv + 1, argv + argc);
  if (!arguments.empty() && (arguments[0] == "--help" || arguments[0] == "-h")) {
    std::cout << interface::Usage("cosim run");
    return 0;
  }
  interface::CommandLine cli;
  try {
    cli = interface::ParseCommandLine(arguments);
    const auto file = interface::ScenarioFile::Load(cli.scenario, cli.sets);
    interface::ValidateTimeSpan(file);
    const auto plan = interface::PlanProcesses(file, arguments);
    const std::string bin_dir = std::filesystem::canonical("/proc/self/exe").parent_path().string();
    return interface::RunProcesses(bin_dir, plan);
  } catch (const Error& e) {
    std::cerr << "cosim run: error: " << e.what() << "\n";
    if (e.code() == ExitCode::kBadInput) interface::WriteInputFailureSummary("cosim run", cli, e.what());
    return static_cast<int>(e.code());
  }
}
