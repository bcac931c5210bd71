#pragma once
// A beam as given in the scenario (model.beams), validated: its node bodies, elements and
// section table. The nodes become bodies of the MultibodyModel ("<beam>.n<k>") before the joints
// are read, so that joints, loads, probes and interface nodes can name them.
#include <string>
#include <vector>

#include "interface/scenario/checks.h"
#include "smooth_solver/beam/beam.h"

namespace cosim::smooth {

struct MultibodyModel;
struct Joint;

struct BeamModel {
  std::string name;
  int nodes_per_element = 3;
  std::vector<int> node_bodies;  // body index of each node, root first
  std::vector<BeamElement> elements;
  BeamTable table;
  double retardation = 0.0;
  double span_start = 0.0, span_end = 0.0;
  // Floor on every director's second moment, as a fraction of m L_e² (BeamElementMass): keeps
  // each node's rotation inertial where the data give no rotary inertia (d1 never has any).
  // 1e-6 is a radius of gyration of L_e/1000 — below any real section's.
  static constexpr double kRotaryFloor = 3e-3;
  double RotaryFloor(const BeamElement& e) const { return kRotaryFloor * e.length * e.length; }
};

// Reads model.beams: appends their node bodies to model->bodies (declared in `body_names`) and
// the beams to model->beams.
void AddBeams(const interface::Checks& checks, interface::NameTable* body_names, MultibodyModel* model);
// After the scenario's joints: the FIXED joints of the beams' root_body clamps, declared in
// `joint_names`.
void AddBeamClamps(const interface::Checks& checks, interface::NameTable* joint_names, MultibodyModel* model);

}  // namespace cosim::smooth
