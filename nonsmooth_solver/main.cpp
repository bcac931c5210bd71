// nonsmooth_solver: a contact process. Standalone, it runs a scene made only of contact
// nodes under the run contract (see interface/run/run_driver.h); with --process NAME it is
// that contact process of a coupled run, served by the coordinator (smooth_solver).
#include "interface/run/errors.h"
#include "interface/run/run_driver.h"
#include "nonsmooth_solver/coupling/served_simulation.h"
#include "nonsmooth_solver/simulation/contact_simulation.h"

int main(int argc, char** argv) {
  using namespace cosim;
  return interface::RunProgram(
      "nonsmooth_solver", argc, argv,
      [](const interface::ScenarioFile& file,
         const interface::CommandLine& cli) -> std::unique_ptr<interface::Simulation> {
        if (!cli.process.empty()) {
          return std::make_unique<nonsmooth::ServedContactSimulation>(
              file, cli.process, [](const interface::ScenarioFile& f, const std::set<std::string>& nodes) {
                return std::make_unique<nonsmooth::ContactSimulation>(f, &nodes);
              });
        }
        if (file.proto().coupling().interface_nodes_size() > 0) {
          file.Fail("coupling.interface_nodes",
                    "the contact nodes are tied to the smooth model: run the coupled scene with scripts/cosim run "
                    "(or nonsmooth_solver --process NAME under a coordinator)");
        }
        return std::make_unique<nonsmooth::ContactSimulation>(file);
      });
}
