#include "smooth_solver/coupling/coordinator.h"

#include <Eigen/Geometry>
#include <cmath>
#include <limits>

#include "interface/run/errors.h"
#include "interface/scenario/checks.h"
#include "smooth_solver/integrator/initial_conditions.h"

namespace cosim::smooth {

using coupling::Envelope;

Coordinator::Coordinator(const MultibodySystem& system, SystemData* data, CgAlpha* integrator, std::vector<Peer> peers,
                         const CouplingSettings& settings)
    : system_(system),
      data_(data),
      integrator_(integrator),
      peers_(std::move(peers)),
      settings_(settings),
      relaxation_(settings.relaxation, 3 * static_cast<int>(system.interface_points.size()),
                  settings.relaxation_factor, -1, settings.reuse_steps) {
  n_ = 3 * static_cast<int>(system.interface_points.size());
  x_ = Eigen::VectorXd::Zero(n_);
  x_tilde_ = x_;
  previous_x_tilde_ = x_;
  x_next_ = x_;
  accepted_x_ = x_;
  solved_x_ = x_;
  previous_accepted_x_ = x_;
  lambda_start_ = lambda_end_ = filtered_start_ = filtered_end_ = x_;
  position_ = x_;
  velocity_ = x_;
  previous_position_ = x_;
  start_velocity_ = x_;
  for (const InterfacePoint& p : system.interface_points) {
    for (int j = 0; j < 3; ++j) coupling_rows_.push_back(p.first_row + j);
  }
  // Until the first step: where the points are, at rest.
  for (size_t k = 0; k < system.interface_points.size(); ++k) {
    for (int j = 0; j < 3; ++j) position_(3 * static_cast<Eigen::Index>(k) + j) = data->imposed[3 * k + j].value;
  }
}

namespace {

// Body `body`'s frame in `state` (natural coordinates [x, u, v, w]: R = [u v w]), advanced by
// `ahead` seconds at constant velocity and angular velocity ω = ½ Σ u_i × u̇_i.
void FillFrame(int body, const DaeState& state, double ahead, coupling::Frame* frame) {
  const Eigen::Index o = kCoordinatesPerBody * body;
  if (!state.q.segment<kCoordinatesPerBody>(o).allFinite() || !state.qdot.segment<kCoordinatesPerBody>(o).allFinite()) {
    throw NumericalError("coupling: the frame of body " + std::to_string(body) +
                         " (carrying a contact process's obstacle) is not finite");
  }
  Eigen::Matrix3d R;
  Eigen::Vector3d omega = Eigen::Vector3d::Zero();
  for (int i = 0; i < 3; ++i) {
    R.col(i) = state.q.segment<3>(o + 3 + 3 * i);
    omega += 0.5 * R.col(i).cross(state.qdot.segment<3>(o + 3 + 3 * i));
  }
  const Eigen::Vector3d v = state.qdot.segment<3>(o);
  const Eigen::Vector3d c = state.q.segment<3>(o) + ahead * v;
  const double angle = omega.norm() * ahead;
  if (angle > 0.0) R = Eigen::AngleAxisd(angle, omega.normalized()).toRotationMatrix() * R;
  for (int i = 0; i < 3; ++i) {
    frame->add_position(c(i));
    frame->add_velocity(v(i));
    frame->add_angular_velocity(omega(i));
    for (int j = 0; j < 3; ++j) frame->add_rotation(R(i, j));
  }
}

}  // namespace

void Coordinator::RestartWithCouplingRowsFree(DaeState state, double t) {
  ConsistentAccelerations(system_, t, &state, &coupling_rows_);
  integrator_->Restart(state);
  // The coupling rows' multipliers are 0 there, and a = q̈: the filtered multipliers too.
  lambda_start_.setZero();
  filtered_start_.setZero();
}

void Coordinator::Handshake(const std::string& scenario_name, double start_time, double step) {
  // The start: accelerations with the coupling rows left out (free interface points, λ = 0),
  // a_0 = q̈_0 (a shifted start would impose end-of-step coordinates at the wrong time).
  RestartWithCouplingRowsFree(integrator_->state(), start_time);
  for (size_t k = 0; k < system_.interface_points.size(); ++k) {
    const Eigen::Vector3d a = system_.interface_points[k].point.Rate(integrator_->state().qddot);  // point acceleration
    for (int j = 0; j < 3; ++j) data_->imposed[3 * k + static_cast<size_t>(j)].acceleration = a(j);
  }
  for (Peer& peer : peers_) {
    auto* hello = peer.channel->Outgoing(-1, 0).mutable_hello();
    hello->set_scenario_name(scenario_name);
    hello->set_process_name(peer.channel->options().peer);
    for (int p : peer.points) hello->add_interface_nodes(system_.interface_points[static_cast<size_t>(p)].contact_node);
    hello->set_start_time(start_time);
    hello->set_step(step);
    for (const MovingObstacle& o : peer.obstacles) {
      hello->add_moving_obstacles(o.name);
      FillFrame(o.body, integrator_->state(), 0.0, hello->add_obstacle_frames());
    }
    peer.channel->Send();
  }
  for (Peer& peer : peers_) {
    const auto& welcome = peer.channel->Receive(Envelope::kWelcome, -1, -1).welcome();
    if (welcome.interface_nodes_size() != static_cast<int>(peer.points.size())) {
      throw InputError("coupling: '" + peer.channel->options().peer + "' welcomed " +
                       std::to_string(welcome.interface_nodes_size()) + " interface nodes, expected " +
                       std::to_string(peer.points.size()));
    }
  }
}

void Coordinator::ReceiveKinematics(int iteration) {
  in_contact_ = false;
  time_to_contact_ = std::numeric_limits<double>::infinity();
  for (Peer& peer : peers_) {
    const auto& k = peer.channel->Receive(Envelope::kKinematics, step_, iteration).kinematics();
    const int expected = 3 * static_cast<int>(peer.points.size());
    if (k.position_size() != expected || k.velocity_size() != expected) {
      throw InputError("coupling: Kinematics from '" + peer.channel->options().peer + "' has " +
                       std::to_string(k.position_size()) + " positions and " + std::to_string(k.velocity_size()) +
                       " velocities; expected " + std::to_string(expected) + " of each");
    }
    for (int i = 0; i < expected; ++i) {
      if (!std::isfinite(k.position(i)) || !std::isfinite(k.velocity(i))) {
        throw InputError("coupling: Kinematics from '" + peer.channel->options().peer + "' of step " +
                         std::to_string(step_) + " has a non-finite value at index " + std::to_string(i) +
                         " (position " + interface::FormatNumber(k.position(i)) + ", velocity " +
                         interface::FormatNumber(k.velocity(i)) + "); expected finite numbers");
      }
    }
    for (int c : k.in_contact()) in_contact_ = in_contact_ || c != 0;
    // An older peer that does not say: a contact is always possible.
    const double ttc = k.has_time_to_contact() ? k.time_to_contact() : 0.0;
    if (std::isnan(ttc) || ttc < 0.0) {
      throw InputError("coupling: Kinematics.time_to_contact from '" + peer.channel->options().peer + "' of step " +
                       std::to_string(step_) + " is " + interface::FormatNumber(ttc) +
                       "; expected a time >= 0 [s] (or +inf)");
    }
    time_to_contact_ = std::min(time_to_contact_, ttc);
    for (size_t i = 0; i < peer.points.size(); ++i) {
      for (int j = 0; j < 3; ++j) {
        const Eigen::Index v = 3 * peer.points[i] + j;
        position_(v) = k.position(3 * static_cast<int>(i) + j);
        velocity_(v) = k.velocity(3 * static_cast<int>(i) + j);
      }
    }
  }
}

void Coordinator::Impose(double h) {
  for (Eigen::Index v = 0; v < n_; ++v) {
    ImposedCoordinate& c = data_->imposed[static_cast<size_t>(v)];
    c.value = position_(v);
    c.rate = velocity_(v);
    c.acceleration = (velocity_(v) - start_velocity_(v)) / h;
  }
}

int Coordinator::Step(double t, double h) {
  const Attempt attempt = Try(t, h);
  if (!attempt.failure.empty()) throw NumericalError(attempt.failure);  // (everything restored)
  if (!attempt.converged) {
    if (settings_.stop_at_max_iterations) {
      integrator_->Restore(start_);
      throw NumericalError(NoConvergence(t, h));
    }
    ++marked_;
  }
  Accept(t, h, attempt.converged);
  return attempt.iterations;
}

std::string Coordinator::NoConvergence(double t, double h) const {
  return "coupling: no convergence in " + std::to_string(settings_.max_iterations) + " iterations at step " +
         std::to_string(step_) + " (t = " + interface::FormatNumber(t + h) + " s): reaction residual " +
         interface::FormatNumber(log_.back().reaction_residual) + " N, displacement change " +
         interface::FormatNumber(log_.back().displacement_change) +
         " m; raise coupling.iteration.max_iterations, choose AITKEN or IQN_ILS, or shorten the step";
}

Coordinator::Attempt Coordinator::Try(double t, double h) {
  Attempt result;
  log_.clear();  // this step's records (the capacity stays: no allocation once warm)
  integrator_->SaveTo(&start_);
  for (Eigen::Index v = 0; v < n_; ++v) start_velocity_(v) = data_->imposed[static_cast<size_t>(v)].rate;
  relaxation_.BeginStep();
  // Predictor: the reactions extrapolated linearly from the last two accepted steps (constant
  // after a start or an impact), scaled to this step's length. With a stiff tie the first
  // residual is the prediction error times the tie's gain, so this is worth an iteration per step.
  const double ratio = accepted_h_ > 0.0 ? h / accepted_h_ : 1.0;
  x_ = accepted_steps_ >= 2 ? Eigen::VectorXd(accepted_x_ + ratio * (accepted_x_ - previous_accepted_x_)) : accepted_x_;
  for (Peer& peer : peers_) {
    auto* begin = peer.channel->Outgoing(step_, 0).mutable_step_begin();
    begin->set_time(t);
    begin->set_step(h);
    for (int p : peer.points) {
      for (int j = 0; j < 3; ++j) begin->mutable_predictor()->add_force(x_(3 * p + j));
    }
    for (const MovingObstacle& o : peer.obstacles) {
      FillFrame(o.body, integrator_->state(), h, begin->mutable_predictor()->add_obstacle_frames());
    }
    peer.channel->Send();
  }
  ReceiveKinematics(0);
  // coupling.iteration.free_flight_margin: no contact can close within the step (every peer's
  // time to contact beyond free_flight_margin steps from the step's end, none acting): the
  // first iteration is accepted if its reaction residual meets the tolerance, without the
  // second iteration that would confirm the kinematics (the displacement test).
  const bool free_flight =
      settings_.free_flight_margin > 0.0 && !in_contact_ && time_to_contact_ > settings_.free_flight_margin * h;
  newton_ = 0;
  // This side failed in iteration `at` (every peer waits for its next message): the integrator back
  // at the step's start; the caller rejects the step (adaptive) or ends the run.
  auto failed = [&](int at, std::string why) {
    integrator_->Restore(start_);
    result.failure = std::move(why);
    result.iterations = at + 1;
    last_iteration_ = at;  // (the StepEnd that rejects it carries this iteration)
    return result;
  };
  // Sends the reactions x_ for `iteration` to every peer (obstacle frames from `frames`) and
  // receives the kinematics they answer with.
  auto exchange = [&](int iteration, const DaeState& frames) {
    for (Peer& peer : peers_) {
      auto* r = peer.channel->Outgoing(step_, iteration).mutable_reactions();
      for (int p : peer.points) {
        for (int j = 0; j < 3; ++j) r->add_force(x_(3 * p + j));
      }
      for (const MovingObstacle& o : peer.obstacles) FillFrame(o.body, frames, 0.0, r->add_obstacle_frames());
      peer.channel->Send();
    }
    ReceiveKinematics(iteration);
  };
  int iteration = 0, backtracks = 0;
  for (;; ++iteration) {
    integrator_->Restore(start_);  // (the imposed coordinates too: they are in the checkpoint's SystemData)
    Impose(h);
    try {
      newton_ += integrator_->Step(t, h, settings_.warm_start && iteration > 0 ? &iterate_ : nullptr);
    } catch (const NumericalError& e) {
      // The relaxation's update (IQN-ILS's above all, extrapolating secants of earlier steps)
      // sent the peers reactions whose kinematics this side cannot solve (observed: the Puma
      // gust's lift-off at 2.975 s: reactions that moved the node 32 m, Newton diverging to
      // |q| ~ 1e158). Back-track from the last iteration that solved: first the plain relaxed
      // update from it with the secants forgotten (the method's first-iteration ω), then halving
      // towards it; ask the peers again — up to kMaxBacktracks times a step, within max_iterations.
      if (iteration == 0 || backtracks >= kMaxBacktracks || iteration + 1 >= settings_.max_iterations) {
        return failed(iteration, e.what());
      }
      ++backtracks;
      ++backtracks_;
      CouplingIterationRecord record;
      record.step = step_;
      record.iteration = iteration;
      record.reaction_residual = std::numeric_limits<double>::infinity();  // no answer: the solve failed
      record.displacement_change = (position_ - previous_position_).lpNorm<Eigen::Infinity>();
      if (backtracks == 1) {
        relaxation_.Forget();
        relaxation_.Next(solved_x_, previous_x_tilde_, &x_);  // previous_x_tilde_: the solved iteration's answer
        record.relaxation_factor = relaxation_.last_factor();
      } else {
        x_ = solved_x_ + 0.5 * (x_ - solved_x_);
        record.relaxation_factor = 0.5;
      }
      log_.push_back(record);
      exchange(iteration + 1, iterate_);  // (position_ now the answer; previous_position_ stays the solved one's)
      continue;
    }
    iterate_ = integrator_->state();  // equal sizes: no allocation once warm
    solved_x_ = x_;
    const Eigen::VectorXd& lambda = integrator_->state().lambda;
    for (size_t k = 0; k < system_.interface_points.size(); ++k) {
      lambda_end_.segment<3>(3 * static_cast<Eigen::Index>(k)) = system_.InterfaceReaction(static_cast<int>(k), lambda);
    }
    // STEP_AVERAGE: the multipliers through CGα's acceleration filter
    // (1 − α_m) λ̃₁ + α_m λ̃₀ = (1 − α_f) λ₁ + α_f λ₀, weighted as its velocity update,
    // (1 − γ) λ̃₀ + γ λ̃₁: h times it is the momentum the smooth side exchanged with the node
    // over the step. END_OF_STEP: λ₁.
    filtered_end_ = ((1.0 - integrator_->alpha_f()) * lambda_end_ + integrator_->alpha_f() * lambda_start_ -
                     integrator_->alpha_m() * filtered_start_) /
                    (1.0 - integrator_->alpha_m());
    if (settings_.step_average_reaction) {
      x_tilde_ = (1.0 - integrator_->gamma()) * filtered_start_ + integrator_->gamma() * filtered_end_;
    } else {
      x_tilde_ = lambda_end_;
    }
    if (!x_tilde_.allFinite()) {
      // (A huge but finite load gives infinite multipliers.) This side's failure, not a message
      // for the peers to refuse.
      return failed(iteration, "coupling: the smooth model's reactions on the interface nodes are not finite after "
                               "coupling iteration " + std::to_string(iteration) + " of the step to t = " +
                               interface::FormatNumber(t + h) + " s");
    }
    CouplingIterationRecord record;
    record.step = step_;
    record.iteration = iteration;
    record.reaction_residual = n_ > 0 ? (x_tilde_ - x_).lpNorm<Eigen::Infinity>() : 0.0;
    record.displacement_change = iteration == 0 ? std::numeric_limits<double>::infinity()
                                                : (position_ - previous_position_).lpNorm<Eigen::Infinity>();
    const double scale = std::max(1.0, n_ > 0 ? x_tilde_.lpNorm<Eigen::Infinity>() : 0.0);
    // Round-off: once the peers' kinematics no longer change beyond round-off, the smooth
    // side's answer x̃ cannot settle closer than its own jitter between the last two iterations
    // (a stiff tie turns 1e-17 m of position round-off into 1e-9 N of reaction): a residual
    // within that jitter passes, whatever the reaction tolerance asks.
    const double position_roundoff =
        64.0 * std::numeric_limits<double>::epsilon() * std::max(1.0, position_.lpNorm<Eigen::Infinity>());
    const bool at_roundoff = iteration > 0 && n_ > 0 && record.displacement_change <= position_roundoff &&
                             record.reaction_residual <= (x_tilde_ - previous_x_tilde_).lpNorm<Eigen::Infinity>();
    result.converged = (record.reaction_residual <= settings_.reaction_tolerance * scale || at_roundoff) &&
                       (iteration > 0 ? record.displacement_change <= settings_.displacement_tolerance
                                      : record.reaction_residual == 0.0);
    if (iteration == 0 && !result.converged && free_flight &&
        record.reaction_residual <= settings_.reaction_tolerance * scale) {
      result.converged = result.free_flight = true;
      ++free_flight_;
    }
    if (result.converged && at_roundoff && record.reaction_residual > settings_.reaction_tolerance * scale) ++at_roundoff_;
    previous_x_tilde_ = x_tilde_;
    if (result.converged || iteration + 1 >= settings_.max_iterations) {
      record.relaxation_factor = 0.0;
      log_.push_back(record);
      break;
    }
    relaxation_.Next(x_, x_tilde_, &x_next_);
    record.relaxation_factor = relaxation_.last_factor();
    log_.push_back(record);
    x_ = x_next_;
    previous_position_ = position_;
    exchange(iteration + 1, integrator_->state());
  }
  last_iteration_ = iteration;
  result.iterations = iteration + 1;
  result.impact = in_contact_ && !was_in_contact_;
  result.contact = in_contact_;
  result.time_to_contact = time_to_contact_;
  return result;
}

void Coordinator::Accept(double t, double h, bool converged) {
  previous_accepted_x_ = accepted_x_;
  accepted_x_ = x_;
  accepted_h_ = h;
  ++accepted_steps_;
  lambda_start_ = lambda_end_;
  filtered_start_ = filtered_end_;
  // A new contact (an impact): the points take their nodes' velocities and the history restarts,
  // unless the scenario keeps the smooth model going (restart_at_impact = false: a regularised
  // tie then carries the velocity jump over the next steps; scenario.proto).
  if (in_contact_ && !was_in_contact_ && settings_.restart_at_impact) {
    DaeState after = integrator_->state();
    ProjectVelocities(system_, t + h, &after);  // the points move with their nodes
    RestartWithCouplingRowsFree(std::move(after), t + h);
    accepted_x_.setZero();  // the impact's reaction does not carry over
    accepted_steps_ = 0;
    relaxation_.Forget();   // nor do the secants of the interface map before it
  }
  was_in_contact_ = in_contact_;
  EndStep(true, converged);
  ++step_;
}

void Coordinator::Reject() {
  integrator_->Restore(start_);
  relaxation_.Forget();  // secants of a step of another length
  EndStep(false, false);
  ++rejected_;
}

void Coordinator::EndStep(bool accepted, bool converged) {
  for (Peer& peer : peers_) {
    auto* end = peer.channel->Outgoing(step_, last_iteration_).mutable_step_end();
    end->set_accepted(accepted);
    end->set_converged(converged);
    peer.channel->Send();
  }
  for (Peer& peer : peers_) peer.channel->Receive(Envelope::kStepEnd, step_, last_iteration_);
}

void Coordinator::Shutdown(int exit_code, const std::string& reason, bool wait_for_replies) {
  for (Peer& peer : peers_) {
    if (peer.channel->peer_stopped()) continue;  // it said Shutdown itself: it is gone
    auto* stop = peer.channel->Outgoing(-1, 0).mutable_shutdown();
    stop->set_exit_code(exit_code);
    stop->set_reason(reason);
    peer.channel->Send();
  }
  if (!wait_for_replies) return;
  for (Peer& peer : peers_) {
    if (!peer.channel->peer_stopped()) peer.channel->Receive(Envelope::kShutdown, -1, -1);
  }
}

}  // namespace cosim::smooth
