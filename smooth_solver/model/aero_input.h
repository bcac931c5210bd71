#pragma once
// model.air as given in the scenario, validated into an AeroModel (air, airfoils, surfaces,
// rotors). Runs after the bodies and beams are known (surfaces and rotors name them).
#include "interface/scenario/checks.h"
#include "smooth_solver/aero/air_loads.h"

namespace cosim::smooth {

struct MultibodyModel;

// Fills model->aero from model.air (nothing when absent). Throws InputError with the place.
void AddAero(const interface::Checks& checks, const interface::NameTable& body_names, MultibodyModel* model);

}  // namespace cosim::smooth
