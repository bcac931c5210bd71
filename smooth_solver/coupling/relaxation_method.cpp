#include "smooth_solver/coupling/relaxation_method.h"

#include <limits>

namespace cosim::smooth {

RelaxationMethod::RelaxationMethod(const CouplingSettings& settings, CouplingIterate* it, InterfaceRows* rows)
    : settings_(settings),
      it_(it),
      rows_(rows),
      relaxation_(settings.relaxation, static_cast<int>(it->x.size()), settings.relaxation_factor, -1,
                  settings.reuse_steps),
      convergence_(settings) {
  solved_x_ = previous_x_tilde_ = previous_position_ = x_next_ = Eigen::VectorXd::Zero(it->x.size());
}

bool RelaxationMethod::FreeFlight(double h) const {
  return settings_.free_flight_margin > 0.0 && !it_->answers.in_contact &&
         it_->answers.time_to_contact > settings_.free_flight_margin * h;
}

void RelaxationMethod::Impose(double h) {
  for (Eigen::Index v = 0; v < it_->x.size(); ++v) rows_->SetPosition(v, it_->answers.position(v));
  rows_->SetRates(it_->answers.velocity, h);
}

bool RelaxationMethod::Converged(int iteration, bool free_flight, CouplingIterationRecord* record, bool* skipped) {
  solved_x_ = it_->x;
  const RelaxationConvergence::Verdict v =
      convergence_.Test(iteration, free_flight, *it_, previous_x_tilde_, previous_position_, record);
  *skipped = v.free_flight;
  if (v.at_roundoff) ++roundoff_steps_;
  previous_x_tilde_ = it_->x_tilde;
  return v.converged;
}

void RelaxationMethod::Next(double /*h*/, CouplingIterationRecord* record) {
  relaxation_.Next(it_->x, it_->x_tilde, &x_next_);
  record->relaxation_factor = relaxation_.last_factor();
  it_->x = x_next_;
  previous_position_ = it_->answers.position;
}

// The relaxation's update (IQN-ILS's above all, extrapolating secants of earlier steps) sent the
// peers reactions whose kinematics this side cannot solve (observed: the Puma gust's lift-off at
// 2.975 s: reactions that moved the node 32 m, Newton diverging to |q| ~ 1e158). Back-track from
// the last iteration that solved: first the plain relaxed update from it with the secants
// forgotten (the method's first-iteration ω), then halving towards it, up to kMaxBacktracks
// times a step and within max_iterations; the coordinator asks the peers again.
bool RelaxationMethod::Backtrack(int iteration, int backtrack, CouplingIterationRecord* record) {
  if (iteration == 0 || backtrack > kMaxBacktracks || iteration + 1 >= settings_.max_iterations) return false;
  record->reaction_residual = std::numeric_limits<double>::infinity();  // no answer: the solve failed
  record->displacement_change = (it_->answers.position - previous_position_).lpNorm<Eigen::Infinity>();
  if (backtrack == 1) {
    relaxation_.Forget();
    relaxation_.Next(solved_x_, previous_x_tilde_, &it_->x);  // previous_x_tilde_: the solved iteration's answer
    record->relaxation_factor = relaxation_.last_factor();
  } else {
    it_->x = solved_x_ + 0.5 * (it_->x - solved_x_);
    record->relaxation_factor = 0.5;
  }
  return true;  // (previous_position_ stays the solved iteration's)
}

std::string RelaxationMethod::ReadMemory(const state::CoordinatorMemory& in) {
  if (!in.has_relaxation()) return {};
  bool restored = false;  // (not restored if saved with other settings: it starts afresh, as they say)
  if (std::string wrong = relaxation_.Read(in.relaxation(), &restored); !wrong.empty()) {
    return "its coordinator's " + wrong;
  }
  return {};
}

}  // namespace cosim::smooth
