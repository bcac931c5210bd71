#include "smooth_solver/integrator/integrator_settings.h"

#include <algorithm>
#include <string>

namespace cosim::smooth {

namespace sc = scenario;

sc::SmoothSettings::Integrator ReadIntegrator(const interface::Checks& checks, const sc::SmoothSettings& s) {
  if (s.integrator() != sc::SmoothSettings::CGALPHA && s.integrator() != sc::SmoothSettings::IDA &&
      s.integrator() != sc::SmoothSettings::CGALPHA_INDEX2) {
    checks.Fail("numerics.smooth.integrator", "expected CGALPHA, CGALPHA_INDEX2 or IDA");
  }
  return s.integrator();
}

IdaSettings ReadIdaSettings(const interface::Checks& checks, const sc::SmoothSettings& s) {
  IdaSettings out;
  out.relative_tolerance =
      checks.Positive("numerics.smooth.ida_relative_tolerance", true, s.ida_relative_tolerance(), "dimensionless");
  out.absolute_tolerance =
      checks.Positive("numerics.smooth.ida_absolute_tolerance", true, s.ida_absolute_tolerance(), "m or m/s");
  return out;
}

CgAlphaSettings ReadCgAlphaSettings(const interface::Checks& checks, const sc::SmoothSettings& s,
                                    const std::vector<RigidBody>& bodies) {
  CgAlphaSettings out;
  out.rho_inf = checks.InRange("numerics.smooth.rho_inf", true, s.rho_inf(), 0.0, 1.0);
  out.tolerance = checks.Positive("numerics.smooth.newton_tolerance", true, s.newton_tolerance(), "dimensionless");
  if (s.newton_max_iterations() < 1) {
    checks.Fail("numerics.smooth.newton_max_iterations",
                "must be >= 1, got " + std::to_string(s.newton_max_iterations()));
  }
  out.max_iterations = s.newton_max_iterations();
  if (s.jacobian_max_age() < 0) {
    checks.Fail(
        "numerics.smooth.jacobian_max_age",
        "must be >= 0 steps (0 = a fresh Newton matrix every iteration), got " + std::to_string(s.jacobian_max_age()));
  }
  out.jacobian_max_age = s.jacobian_max_age();
  if (s.elastic_force() != sc::SmoothSettings::GEMM && s.elastic_force() != sc::SmoothSettings::END_POINT) {
    checks.Fail("numerics.smooth.elastic_force", "expected GEMM or END_POINT");
  }
  out.gemm = s.elastic_force() == sc::SmoothSettings::GEMM;
  if (s.constraint_form() != sc::SmoothSettings::INDEX3 &&
      s.constraint_form() != sc::SmoothSettings::INDEX2_PROJECTED) {
    checks.Fail("numerics.smooth.constraint_form", "expected INDEX3 or INDEX2_PROJECTED");
  }
  out.form =
      s.constraint_form() == sc::SmoothSettings::INDEX3 ? ConstraintForm::kIndex3 : ConstraintForm::kIndex2Projected;
  if (s.has_jacobian_frame() && !s.jacobian_frame().empty()) {  // ("": none, e.g. a --set that turns it off)
    const auto it =
        std::find_if(bodies.begin(), bodies.end(), [&](const RigidBody& b) { return b.name == s.jacobian_frame(); });
    if (it == bodies.end()) {
      checks.Fail("numerics.smooth.jacobian_frame", "no rigid body named '" + s.jacobian_frame() + "'");
    } else if (s.jacobian_max_age() == 0) {
      checks.Fail("numerics.smooth.jacobian_frame",
                  "set, but numerics.smooth.jacobian_max_age is 0 (no matrix is reused)");
    } else {
      out.frame_body = static_cast<int>(it - bodies.begin());
    }
  }
  return out;
}

}  // namespace cosim::smooth
