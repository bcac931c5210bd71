// penalty_solver: a second contact program (docs/protocol.md). The same contact nodes and
// planes as nonsmooth_solver, each contact a compliant Hunt–Crossley law integrated by RK4
// (penalty/penalty_simulation.h). Standalone it runs a scene of contact nodes under the run
// contract; with --process NAME it is that contact process of a coupled run
// (coupling.processes[NAME].program: "penalty_solver").
#include "interface/run/run_driver.h"
#include "nonsmooth_solver/coupling/served_simulation.h"
#include "nonsmooth_solver/penalty/penalty_simulation.h"

int main(int argc, char** argv) {
  using namespace cosim;
  return interface::RunProgram(
      "penalty_solver", argc, argv,
      [](const interface::ScenarioFile& file,
         const interface::CommandLine& cli) -> std::unique_ptr<interface::Simulation> {
        if (!cli.process.empty()) {
          return std::make_unique<nonsmooth::ServedContactSimulation>(
              file, cli.process, [](const interface::ScenarioFile& f, const std::set<std::string>& nodes) {
                return std::make_unique<nonsmooth::PenaltySimulation>(f, &nodes);
              });
        }
        if (file.proto().coupling().interface_nodes_size() > 0) {
          file.Fail("coupling.interface_nodes",
                    "the contact nodes are tied to the smooth model: run the coupled scene with scripts/cosim run "
                    "(or penalty_solver --process NAME under a coordinator)");
        }
        return std::make_unique<nonsmooth::PenaltySimulation>(file);
      });
}
