#pragma once
// model.beams as given in the scenario, validated into BeamModels (smooth_solver/beam/): their
// node bodies, elements and section tables. The nodes become bodies of the MultibodyModel
// ("<beam>.n<k>") before the joints are read, so that joints, loads, probes and interface nodes
// can name them. Throws InputError with the place.
#include "interface/scenario/checks.h"
#include "smooth_solver/model/multibody_model.h"

namespace cosim::smooth {

// Reads model.beams: appends their node bodies to model->bodies (declared in `body_names`) and
// the beams to model->beams.
void AddBeams(const interface::Checks& checks, interface::NameTable* body_names, MultibodyModel* model);
// After the scenario's joints: the FIXED joints of the beams' root_body clamps, declared in
// `joint_names`; root bodies looked up in `body_names`.
void AddBeamClamps(const interface::Checks& checks, const interface::NameTable& body_names,
                   interface::NameTable* joint_names, MultibodyModel* model);

}  // namespace cosim::smooth
