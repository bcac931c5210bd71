// smooth_solver: the multibody solver. Standalone, it runs a scene of rigid bodies and
// joints (CGα, DYNAMIC analysis), or elastic bodies in a STATIC analysis, under the run
// contract (see interface/run/run_driver.h).
#include "interface/run/run_driver.h"
#include "smooth_solver/coupling/coupled_simulation.h"
#include "smooth_solver/simulation/elastic_static_simulation.h"
#include "smooth_solver/simulation/modal_simulation.h"
#include "smooth_solver/simulation/multibody_simulation.h"

int main(int argc, char** argv) {
  using namespace cosim;
  return interface::RunProgram(
      "smooth_solver", argc, argv,
      [](const interface::ScenarioFile& file, const interface::CommandLine&) -> std::unique_ptr<interface::Simulation> {
        if (file.proto().numerics().smooth().analysis() == scenario::SmoothSettings::STATIC) {
          return std::make_unique<smooth::ElasticStaticSimulation>(file);
        }
        if (file.proto().numerics().smooth().analysis() == scenario::SmoothSettings::MODES) {
          return std::make_unique<smooth::ModalSimulation>(file);
        }
        if (file.proto().coupling().interface_nodes_size() > 0) {
          return std::make_unique<smooth::CoupledSmoothSimulation>(file);  // the coordinator
        }
        return std::make_unique<smooth::MultibodySimulation>(file);
      });
}
