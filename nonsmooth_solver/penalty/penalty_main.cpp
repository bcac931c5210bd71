// penalty_solver: a second contact program (docs/protocol.md). The same contact nodes and
// planes as nonsmooth_solver, each contact a compliant Hunt–Crossley law integrated by the
// implicit trapezoidal rule (penalty/penalty_simulation.h). Standalone it runs a scene of
// contact nodes under the run contract; with --process NAME it is that contact process of a
// coupled run (coupling.processes[NAME].program: "penalty_solver").
#include "nonsmooth_solver/coupling/served_simulation.h"
#include "nonsmooth_solver/penalty/penalty_simulation.h"

int main(int argc, char** argv) {
  using namespace cosim::nonsmooth;
  return RunContactProgram("penalty_solver", argc, argv,
                           [](const cosim::interface::ScenarioFile& file, const std::set<std::string>* nodes) {
                             return std::make_unique<PenaltySimulation>(file, nodes);
                           });
}
