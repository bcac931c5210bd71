// nonsmooth_solver: a contact process (Moreau–Jean, LCP via Siconos Numerics). Standalone, it
// runs a scene made only of contact nodes under the run contract (see
// interface/run/run_driver.h); with --process NAME it is that contact process of a coupled run,
// served by the coordinator (smooth_solver).
#include "nonsmooth_solver/coupling/served_simulation.h"
#include "nonsmooth_solver/simulation/contact_simulation.h"

int main(int argc, char** argv) {
  using namespace cosim::nonsmooth;
  return RunContactProgram("nonsmooth_solver", argc, argv,
                           [](const cosim::interface::ScenarioFile& file, const std::set<std::string>* nodes) {
                             return std::make_unique<ContactSimulation>(file, nodes);
                           });
}
