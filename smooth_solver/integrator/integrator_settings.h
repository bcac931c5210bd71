#pragma once
// The smooth integrators' numerics (numerics.smooth in the scenario, proto/scenario/numerics.proto
// SmoothSettings), read and checked beside the integrators they set: which integrator, CGα's
// settings (cgalpha.h) and IDA's (ida_reference.h). Each throws InputError naming the field.
#include <vector>

#include "interface/scenario/checks.h"
#include "scenario.pb.h"
#include "smooth_solver/integrator/cgalpha.h"
#include "smooth_solver/integrator/ida_reference.h"
#include "smooth_solver/model/multibody_model.h"

namespace cosim::smooth {

// numerics.smooth.integrator: CGALPHA, CGALPHA_INDEX2 or IDA.
scenario::SmoothSettings::Integrator ReadIntegrator(const interface::Checks& checks, const scenario::SmoothSettings& s);

// numerics.smooth.ida_relative_tolerance and ida_absolute_tolerance.
IdaSettings ReadIdaSettings(const interface::Checks& checks, const scenario::SmoothSettings& s);

// numerics.smooth's rho_inf, newton_tolerance, newton_max_iterations, jacobian_max_age,
// elastic_force, constraint_form and jacobian_frame (a body of `bodies`, by name).
CgAlphaSettings ReadCgAlphaSettings(const interface::Checks& checks, const scenario::SmoothSettings& s,
                                    const std::vector<RigidBody>& bodies);

}  // namespace cosim::smooth
