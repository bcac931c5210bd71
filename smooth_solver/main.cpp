// smooth_solver: the rigid multibody solver (CGα). Standalone, it runs a scene of rigid
// bodies and joints under the run contract (see interface/run/run_driver.h).
#include "interface/run/run_driver.h"
#include "smooth_solver/simulation/multibody_simulation.h"

int main(int argc, char** argv) {
  return cosim::interface::RunProgram("smooth_solver", argc, argv, [](const cosim::interface::ScenarioFile& file) {
    return std::make_unique<cosim::smooth::MultibodySimulation>(file);
  });
}
