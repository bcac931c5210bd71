#pragma once
// A beam as given in the scenario (model.beams), validated: its node bodies, elements and
// section table. The nodes become bodies of the MultibodyModel ("<beam>.n<k>") before the joints
// are read, so that joints, loads, probes and interface nodes can name them.
#include <Eigen/Core>

#include <algorithm>
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
  // The untwisted section axes in the initial configuration: chordwise d2, flapwise d3.
  Eigen::Vector3d d2_0 = Eigen::Vector3d::UnitY(), d3_0 = Eigen::Vector3d::UnitZ();
  // Floor on every director's second moment, kRotaryFloor · m · ℓ² with ℓ = max(L_e, L/10)
  // (BeamElementMass): keeps each node's rotation inertial where the data give no rotary
  // inertia (d1 never has any: a section has no thickness along the span). A radius of gyration
  // of 5.5 % of ℓ — for the Puma's 7 m blade 4 cm, below its sections' own (≈ 6 cm thick). Without
  // it the section rotations against GA vibrate at ωh ~ 1e3 at h = 1e-4 s, their director rates
  // tilt the velocity rows of CGα's matrix and the position projection stalls; ℓ stops shrinking
  // at L/10 because a floor vanishing under refinement brings that back (20 quadratic elements
  // per Puma blade failed with ℓ = L_e).
  static constexpr double kRotaryFloor = 3e-3;
  double RotaryFloor(const BeamElement& e) const {
    const double l = std::max(e.length, 0.1 * (span_end - span_start));
    return kRotaryFloor * l * l;
  }
};

// Reads model.beams: appends their node bodies to model->bodies (declared in `body_names`) and
// the beams to model->beams.
void AddBeams(const interface::Checks& checks, interface::NameTable* body_names, MultibodyModel* model);
// After the scenario's joints: the FIXED joints of the beams' root_body clamps, declared in
// `joint_names`; root bodies looked up in `body_names`.
void AddBeamClamps(const interface::Checks& checks, const interface::NameTable& body_names,
                   interface::NameTable* joint_names, MultibodyModel* model);

}  // namespace cosim::smooth
