// cosim_launch: `scripts/cosim run SCENARIO [--out DIR] [--set P=V]...` ends here. It reads
// the scenario, decides which processes the run needs, starts them with the same command
// line and passes their exit status on. A single-solver run's process validates the scenario
// itself and writes the summary of a bad-input failure.
//
// `--print-scenario`: print the scenario as read (overrides applied, defaults filled in) as JSON
// with the schema's field names and exit; scripts (the studies) read scenarios this way.
#include <google/protobuf/util/json_util.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <limits>

#include "interface/launcher/launcher.h"
#include "interface/run/run_driver.h"
#include "interface/scenario/coupling_plan.h"

int main(int argc, char** argv) {
  using namespace cosim;
  std::vector<std::string> arguments(argv + 1, argv + argc);
  if (!arguments.empty() && (arguments[0] == "--help" || arguments[0] == "-h")) {
    std::cout << interface::Usage("cosim run")
              << "  --print-scenario  print the scenario as read (parameters and patterns expanded, overrides\n"
                 "             applied, defaults filled in) as JSON with the schema's field names, and exit\n";
    return 0;
  }
  const auto print = std::find(arguments.begin(), arguments.end(), "--print-scenario");
  const bool print_scenario = print != arguments.end();
  if (print_scenario) arguments.erase(print);
  interface::CommandLine cli;
  try {
    cli = interface::ParseCommandLine(arguments);
    const auto file = interface::ScenarioFile::Load(cli.scenario, cli.sets);
    if (print_scenario) {
      scenario::Scenario filled = file.proto();
      interface::MaterializeDefaults(&filled);
      google::protobuf::util::JsonPrintOptions options;
      options.preserve_proto_field_names = true;
      std::string json;
      if (!google::protobuf::util::MessageToJsonString(filled, &json, options).ok()) return 3;
      std::cout << json << "\n";
      return 0;
    }
    for (const auto& w : file.warnings()) std::cerr << "cosim run: warning: " << w << "\n";
    interface::ValidateTimeSpan(file);
    const interface::PrivateFolder sockets;
    const auto plan = interface::PlanProcesses(file, cli, arguments, sockets.path());
    if (plan.size() > 1) std::cerr << "cosim: coupling sockets in " << sockets.path() << " (removed at the end)\n";
    const std::string bin_dir = std::filesystem::canonical("/proc/self/exe").parent_path().string();
    // A process of a coupled run stopped for twice coupling.timeout is hung (launcher.h).
    const double stopped_limit =
        plan.size() > 1 ? 2.0 * interface::ReadChannelTiming(file).timeout : std::numeric_limits<double>::infinity();
    return interface::RunProcesses(bin_dir, plan, cli, stopped_limit);
  } catch (const Error& e) {
    std::cerr << "cosim run: error: " << e.what() << "\n";
    interface::WriteFailureSummary("cosim run", cli, e.code(), e.what());
    return static_cast<int>(e.code());
  } catch (const std::exception& e) {
    std::cerr << "cosim run: error: " << e.what() << "\n";
    interface::WriteFailureSummary("cosim run", cli, ExitCode::kPeerFailure, e.what());
    return static_cast<int>(ExitCode::kPeerFailure);
  }
}
