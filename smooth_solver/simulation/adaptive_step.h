#pragma once
// numerics.adaptive: the step-size controller. It drives a Stepper (integrator/stepper.h) from
// the run's time to a target: each step's size from the last one's error estimate and the time
// to the next contact, tried, then accepted or rejected and tried again smaller. It keeps the
// controller's state (the next step, the counts) and nothing of the model's.
#include <functional>
#include <limits>

#include "interface/scenario/checks.h"
#include "scenario.pb.h"
#include "smooth_solver/integrator/stepper.h"
#include "smooth_solver/model/multibody_system.h"

namespace cosim::smooth {

struct AdaptiveSettings {
  bool on = false;
  bool land = false;  // coupled: steps end on the output times (no interpolation of the peers' states)
  double relative = 0.0, absolute = 0.0, min_step = 0.0, max_step = 0.0, contact_step = 0.0;
};

// numerics.adaptive (proto/scenario/numerics.proto AdaptiveStep), its steps landing on the output
// times if `coupled`. Throws InputError naming the field. (Whether the integrator can take them,
// the run asks it: IntegratorCapabilities::error_estimate.)
AdaptiveSettings ReadAdaptiveSettings(const interface::Checks& checks, const scenario::Numerics& numerics,
                                      bool coupled);

class AdaptiveController {
 public:
  AdaptiveController() = default;
  explicit AdaptiveController(const AdaptiveSettings& settings) : settings_(settings) {}
  const AdaptiveSettings& settings() const { return settings_; }

  // Error-controlled steps of `stepper` from t until `target` is reached (or passed, standalone;
  // landed on, with `land`), none past `end`. `accepted(t, h, iterations)` records each accepted
  // step, after the stepper has kept it. NumericalError when the step would fall below
  // min_step. Returns the time reached.
  double Advance(double t, double target, double end, Stepper& stepper, const MultibodySystem& system,
                 const std::function<void(double t, double h, int iterations)>& accepted);

  // The next step's size (0 before the first: Advance then starts from `first`); a restart
  // continues with the one a run saved.
  double next_step() const { return h_next_; }
  void set_next_step(double h) { h_next_ = h; }
  void StartWith(double first) {
    if (h_next_ <= 0.0) h_next_ = first;
  }
  long accepted() const { return accepted_; }
  long rejected() const { return rejected_; }
  double smallest_step() const { return accepted_ > 0 ? smallest_ : 0.0; }
  double largest_step() const { return largest_; }

 private:
  // e = |β − 1/6| h² (a_{n+1} − a_n), weighted by the tolerances: its RMS norm.
  double ErrorNorm(double h, const Stepper& stepper);

  AdaptiveSettings settings_;
  double h_next_ = 0.0;
  double peer_time_to_contact_ = std::numeric_limits<double>::infinity();
  double smallest_ = std::numeric_limits<double>::infinity(), largest_ = 0.0;
  long accepted_ = 0, rejected_ = 0;
  Eigen::VectorXd error_;  // ErrorNorm's estimate (its buffer)
};

}  // namespace cosim::smooth
