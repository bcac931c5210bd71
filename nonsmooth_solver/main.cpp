// nonsmooth_solver: a contact process. Standalone, it runs a scene made only of contact
// nodes under the run contract (see interface/run/run_driver.h).
#include "interface/run/run_driver.h"
#include "nonsmooth_solver/simulation/contact_simulation.h"

int main(int argc, char** argv) {
  return cosim::interface::RunProgram("nonsmooth_solver", argc, argv, [](const cosim::interface::ScenarioFile& file) {
    return std::make_unique<cosim::nonsmooth::ContactSimulation>(file);
  });
}
