#pragma once
// The Moreau–Jean integrator's numerics (numerics.nonsmooth in the scenario,
// proto/scenario/numerics.proto NonsmoothSettings), read and checked beside the integrator they
// set. The contact model (model/contact_model.h) is what is integrated; these are how.
#include "interface/scenario/checks.h"
#include "nonsmooth_solver/lcp/lcp_solver.h"
#include "scenario.pb.h"

namespace cosim::nonsmooth {

enum class FrictionModel { kPolyhedralLcp, kSiconosFc3d };

struct MoreauJeanSettings {
  // θ of the scheme, Eq. (3a)-(3b) of the rotor-sailing paper; (0, 1].
  double theta = 0.5;
  // Predicted gap [m] at or below which a contact enters the LCP.
  double activation_gap = 1e-10;
  // Solve the contacts of each NodeGroup in an LCP of its own (the same solution as one LCP).
  bool split_independent_lcps = true;
  FrictionModel friction_model = FrictionModel::kPolyhedralLcp;
  int friction_facets = 8;  // tangent directions of the polyhedral cone, >= 3
  LcpOptions lcp;
};

// numerics.nonsmooth of `file` (its theta, activation_gap, split_independent_lcps, friction model
// and facets, lcp). Throws InputError naming the field it refuses.
MoreauJeanSettings ReadMoreauJeanSettings(const interface::Checks& checks, const scenario::NonsmoothSettings& ns);
MoreauJeanSettings ReadMoreauJeanSettings(const interface::ScenarioFile& file);

}  // namespace cosim::nonsmooth
