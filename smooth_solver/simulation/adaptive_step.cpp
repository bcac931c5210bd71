#include "smooth_solver/simulation/adaptive_step.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "interface/base/errors.h"
#include "interface/scenario/checks.h"

namespace cosim::smooth {

AdaptiveSettings ReadAdaptiveSettings(const interface::Checks& checks, const scenario::Numerics& numerics,
                                      bool coupled) {
  const scenario::AdaptiveStep& adaptive = numerics.adaptive();
  AdaptiveSettings a;
  a.on = true;
  a.land = coupled;
  a.relative = checks.Positive("numerics.adaptive.relative", true, adaptive.relative(), "dimensionless");
  a.absolute = checks.Positive("numerics.adaptive.absolute", true, adaptive.absolute(), "m");
  a.min_step = checks.Positive("numerics.adaptive.min_step", true, adaptive.min_step(), "s");
  a.max_step = adaptive.has_max_step() ? checks.Positive("numerics.adaptive.max_step", true, adaptive.max_step(), "s")
                                       : 100.0 * numerics.step();
  a.contact_step = adaptive.has_contact_step()
                       ? checks.Positive("numerics.adaptive.contact_step", true, adaptive.contact_step(), "s")
                       : 0.1 * numerics.step();
  // (Read by the contact processes of a coupled run; checked here too, so that no scene carries a bad one.)
  checks.NonNegative("numerics.adaptive.resting_speed", adaptive.resting_speed(), "m/s");
  if (a.max_step < a.min_step) {
    checks.Fail("numerics.adaptive.max_step", "must be >= min_step = " + interface::FormatNumber(a.min_step) +
                                                  " s, got " + interface::FormatNumber(a.max_step) + " s");
  }
  return a;
}

double AdaptiveController::Advance(double t, double target, double end, Stepper& stepper, const MultibodySystem& system,
                                   const std::function<void(double t, double h, int iterations)>& accepted) {
  const AdaptiveSettings& s = settings_;
  const double eps = 1e-12 * std::max(1.0, std::abs(target));
  while (t < target - eps) {
    double step = std::min(h_next_, s.max_step);
    const DaeState& now = stepper.integrator().state();
    // Half the time to a contact at the present closing rate (the approach may accelerate): the
    // steps shorten geometrically towards it, and the last enters it by about contact_step. The
    // contact processes' contacts (coupled) count as the smooth model's own.
    const double to_contact = std::min(system.TimeToContact(now.q, now.qdot), peer_time_to_contact_);
    step = std::min(step, std::max(0.5 * to_contact + s.contact_step, s.min_step));
    // Coupled: land on the output time in equal steps (no sliver of a step before it; the same h
    // from row to row while the controller keeps it, so that a reused Newton matrix stays valid).
    if (s.land) step = (target - t) / std::ceil((target - t) / step - 1e-9);
    if (t + step > end - eps) step = end - t;  // the run ends on its end time
    const StepAttempt attempt = stepper.TryStep(t, step);
    double norm = std::numeric_limits<double>::infinity();
    if (!attempt.failed) {
      // A step in which a contact process's contact closed (an impact: velocities jumped) is not
      // the smooth motion the estimate measures: the next ones are contact_step long instead. (A
      // contact that stays closed, a blade resting on its stop, is tested as any motion.)
      norm = attempt.impact ? 0.0 : ErrorNorm(step, stepper);
    }
    if (!(norm <= 1.0)) {  // rejected: the same step again, smaller
      h_next_ = step * (std::isfinite(norm) ? std::clamp(0.9 * std::cbrt(1.0 / norm), 0.2, 0.9) : 0.25);
      std::string why;  // (asked before the rejection, while the attempt's state is there to describe)
      if (h_next_ < s.min_step) {
        why = attempt.failed ? stepper.WhyFailed() : "the error estimate " + interface::FormatNumber(norm) + " > 1";
      }
      stepper.Reject();
      ++rejected_;
      if (h_next_ < s.min_step) {
        throw NumericalError("numerics.adaptive: the step would fall below min_step = " +
                             interface::FormatNumber(s.min_step) + " s at t = " + interface::FormatNumber(t) + " s (" +
                             interface::FormatNumber(step) + " s rejected: " + why + ")");
      }
      continue;
    }
    stepper.Accept(t, step);
    accepted(t, step, attempt.iterations);
    t += step;
    peer_time_to_contact_ = attempt.time_to_contact;
    ++accepted_;
    smallest_ = std::min(smallest_, step);
    largest_ = std::max(largest_, step);
    // Growth below 1.25× is not taken (as RADAU5 does): an unchanged h keeps a reused Newton
    // matrix valid (jacobian_max_age), which a step that changes by a few percent would drop.
    double growth = norm > 0.0 ? std::clamp(0.9 * std::cbrt(1.0 / norm), 0.2, 2.0) : 2.0;
    if (growth >= 1.0 && growth < 1.25) growth = 1.0;
    if (step < h_next_) growth = std::max(growth, h_next_ / step);  // a step cut to land or before a contact
    h_next_ = std::min(step * growth, s.max_step);
    // After an impact: steps of contact_step, growing again under the controller.
    if (attempt.impact) h_next_ = std::min(h_next_, std::max(s.contact_step, s.min_step));
  }
  return t;
}

double AdaptiveController::ErrorNorm(double h, const Stepper& stepper) {
  // e = |β − 1/6| h² (a_{n+1} − a_n): the local error of the Newmark position update (Zienkiewicz &
  // Xie 1991), here on the generalised-α acceleration variable.
  const CgAlpha& cg = stepper.integrator();
  const double c = std::abs(cg.beta() - 1.0 / 6.0) * h * h;
  const Eigen::VectorXd& q = cg.state().q;
  error_ = c * (cg.acceleration_variable() - stepper.start().a);
  double sum = 0.0;
  for (Eigen::Index i = 0; i < q.size(); ++i) {
    const double w = settings_.absolute + settings_.relative * std::abs(q(i));
    sum += (error_(i) / w) * (error_(i) / w);
  }
  return std::sqrt(sum / static_cast<double>(std::max<Eigen::Index>(q.size(), 1)));
}

}  // namespace cosim::smooth
