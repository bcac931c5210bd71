// smooth_solver: the multibody solver. Standalone, it runs a scene of rigid bodies, joints and
// beams (CGα, DYNAMIC analysis; STATIC: their equilibrium at each output time; MODES: their
// modes), or hex27 elastic bodies alone in a STATIC analysis, under the run contract (see
// interface/run/run_driver.h).
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
        const scenario::Model& model = file.proto().model();
        if (file.proto().numerics().smooth().analysis() == scenario::SmoothSettings::STATIC &&
            model.beams_size() == 0 && model.bodies_size() == 0) {
          return std::make_unique<smooth::ElasticStaticSimulation>(file);  // hex27 bodies alone
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
