#pragma once
// A beam of the model: its node bodies, elements and section table, as the scenario's
// model.beams gives them once validated (smooth_solver/model/beam_input.h reads them).
#include <Eigen/Core>
#include <algorithm>
#include <string>
#include <vector>

#include "smooth_solver/beam/beam.h"

namespace cosim::smooth {

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
  // Floor on the rotary inertia of bending, 2 f m per length with f = kRotaryFloor · ℓ² and
  // ℓ = max(L_e, L/10) (BeamElementMass puts it on d1, which has no inertia of its own: a section
  // has no thickness along the span); torsion keeps the data's polar moment, floored at 2 f m
  // only where the data give less (an earlier floor, f m on every director, added 2 f m to
  // torsion everywhere, +23 % on the Puma). It keeps each node's rotation inertial where the data
  // give no rotary inertia: a radius of gyration √(2f) = 7.7 % of ℓ, 5.5 cm on the Puma's blade
  // of 10 elements. Without it the section rotations against GA vibrate at ωh ~ 1e3 at h = 1e-4 s,
  // their director rates tilt the velocity rows of CGα's matrix and the position projection
  // stalls; ℓ stops shrinking at L/10 because a floor vanishing under refinement brings that back
  // (20 quadratic elements per Puma blade failed with ℓ = L_e).
  static constexpr double kRotaryFloor = 3e-3;
  double RotaryFloor(const BeamElement& e) const {
    const double l = std::max(e.length, 0.1 * (span_end - span_start));
    return kRotaryFloor * l * l;
  }
};

}  // namespace cosim::smooth
