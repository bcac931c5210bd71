// smooth_solver: the rigid/elastic multibody solver. This build validates the multibody
// part of a scenario (bodies, joints, drives); the CGα and IDA integrators arrive with issue 4,
// so a run that needs them ends with exit code 2 and a message that says so.
#include <iostream>

#include "interface/run/errors.h"
#include "interface/run/run_driver.h"
#include "smooth_solver/model/multibody_model.h"

int main(int argc, char** argv) {
  using namespace cosim;
  return interface::RunProgram("smooth_solver", argc, argv,
                               [](const interface::ScenarioFile& file) -> std::unique_ptr<interface::Simulation> {
                                 smooth::BuildMultibodyModel(file);
                                 throw InputError(file.path() +
                                                  ": the scenario is valid, but this build of smooth_solver cannot "
                                                  "integrate rigid or elastic bodies yet (CGα arrives with issue 4)");
                               });
}
