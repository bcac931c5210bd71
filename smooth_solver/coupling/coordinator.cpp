#include "smooth_solver/coupling/coordinator.h"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "interface/run/errors.h"
#include "interface/scenario/checks.h"
#include "smooth_solver/integrator/initial_conditions.h"
#include "smooth_solver/simulation/saved_state.h"

namespace cosim::smooth {

using coupling::Envelope;

Coordinator::Coordinator(const MultibodySystem& system, SystemData* data, CgAlpha* integrator, std::vector<Peer> peers,
                         const CouplingSettings& settings)
    : system_(system),
      data_(data),
      integrator_(integrator),
      peers_(std::move(peers)),
      settings_(settings),
      relaxation_(settings.relaxation, 3 * static_cast<int>(system.interface_points.size()), settings.relaxation_factor,
                  -1, settings.reuse_steps) {
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
  const size_t points = system.interface_points.size();
  for (auto* blocks : {&sensitivity_, &stiffness_, &response_, &response_axes_, &accepted_sensitivity_}) {
    blocks->assign(points, Eigen::Matrix3d::Zero());
  }
  applied_ = sent_position_ = accepted_position_ = accepted_velocity_ = accepted_acceleration_ = x_;
  accepted_offset_ = previous_accepted_position_ = previous_accepted_velocity_ = x_;
  sent_frames_.resize(peers_.size());
  contact_.assign(points, false);
  was_contact_ = contact_;
  // Until the first step: where the points are, at rest.
  for (size_t k = 0; k < system.interface_points.size(); ++k) {
    for (int j = 0; j < 3; ++j) position_(3 * static_cast<Eigen::Index>(k) + j) = data->imposed[3 * k + j].value;
  }
}

namespace {

// Body `body`'s frame in `state` (natural coordinates [x, u, v, w]: R = [u v w]), advanced by
// `ahead` seconds at constant velocity and angular velocity ω = ½ Σ u_i × u̇_i; returns its
// origin and rotation.
std::pair<Eigen::Vector3d, Eigen::Matrix3d> FillFrame(int body, const DaeState& state, double ahead,
                                                      coupling::Frame* frame) {
  const Eigen::Index o = kCoordinatesPerBody * body;
  if (!state.q.segment<kCoordinatesPerBody>(o).allFinite() || !state.qdot.segment<kCoordinatesPerBody>(o).allFinite()) {
    throw NumericalError("coupling: the frame of body " + std::to_string(body) +
                         " (carrying a contact process's obstacle) is not finite");
  }
  Eigen::Matrix3d R = BodyAxes(state.q, body);
  const Eigen::Vector3d omega = BodyAngularRate(state.q, state.qdot, body);
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
  return {c, R};
}

using Block = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>;

}  // namespace

void Coordinator::RestartWithCouplingRowsFree(DaeState state, double t, const std::vector<int>& points) {
  std::vector<int> rows;
  for (int k : points) {
    for (int j = 0; j < 3; ++j) rows.push_back(system_.interface_points[static_cast<size_t>(k)].first_row + j);
  }
  ConsistentAccelerations(system_, *data_, t, &state, &rows);
  integrator_->Restart(state);
  // The freed rows' multipliers are 0 there, and a = q̈: their filtered multipliers too; the
  // others' are the state's.
  StartReactionsFrom(state);
}

void Coordinator::SaveMemory(state::CoordinatorMemory* out) const {
  out->set_points(static_cast<int>(system_.interface_points.size()));
  AddValues(accepted_x_, out->mutable_accepted_x());
  AddValues(previous_accepted_x_, out->mutable_previous_accepted_x());
  out->set_accepted_steps(accepted_steps_);
  out->set_accepted_h(accepted_h_);
  out->set_previous_accepted_h(previous_accepted_h_);
  AddValues(lambda_start_, out->mutable_lambda_start());
  AddValues(filtered_start_, out->mutable_filtered_start());
  AddValues(accepted_position_, out->mutable_accepted_position());
  AddValues(accepted_velocity_, out->mutable_accepted_velocity());
  AddValues(accepted_acceleration_, out->mutable_accepted_acceleration());
  AddValues(previous_accepted_position_, out->mutable_previous_accepted_position());
  AddValues(previous_accepted_velocity_, out->mutable_previous_accepted_velocity());
  AddValues(accepted_offset_, out->mutable_accepted_offset());
  for (const Eigen::Matrix3d& S : sensitivity_) {
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) out->add_sensitivity(S(i, j));
    }
  }
  out->set_offset_known(offset_known_);
  for (const bool c : was_contact_) out->add_was_contact(c);
  relaxation_.Save(out->mutable_relaxation());
}

std::string Coordinator::RestoreMemory(const state::CoordinatorMemory& in) {
  const size_t points = system_.interface_points.size();
  if (in.points() != static_cast<int>(points)) {
    return "its coordinator's memory is of " + std::to_string(in.points()) + " interface points, not " +
           std::to_string(points);
  }
  // Read into copies: a refused memory changes nothing.
  constexpr int kFields = 11;
  const std::pair<const char*, const google::protobuf::RepeatedField<double>*> fields[kFields] = {
      {"accepted_x", &in.accepted_x()},
      {"previous_accepted_x", &in.previous_accepted_x()},
      {"lambda_start", &in.lambda_start()},
      {"filtered_start", &in.filtered_start()},
      {"accepted_position", &in.accepted_position()},
      {"accepted_velocity", &in.accepted_velocity()},
      {"accepted_acceleration", &in.accepted_acceleration()},
      {"previous_accepted_position", &in.previous_accepted_position()},
      {"previous_accepted_velocity", &in.previous_accepted_velocity()},
      {"accepted_offset", &in.accepted_offset()},
      {"sensitivity", &in.sensitivity()}};
  Eigen::VectorXd v[kFields];
  for (int f = 0; f < kFields; ++f) {
    const int size = f == kFields - 1 ? 9 * static_cast<int>(points) : n_;  // sensitivity: 3 × 3 per point
    if (!ReadValues(*fields[f].second, size, &v[f])) {
      return std::string("its coordinator's ") + fields[f].first + " has " + std::to_string(fields[f].second->size()) +
             " values, not " + std::to_string(size);
    }
    if (std::string bad = NonFinite({fields[f]}, "coordinator's "); !bad.empty()) return bad;
  }
  if (in.was_contact_size() != static_cast<int>(points)) {
    return "its coordinator's was_contact has " + std::to_string(in.was_contact_size()) + " values, not " +
           std::to_string(points);
  }
  if (!std::isfinite(in.accepted_h()) || !std::isfinite(in.previous_accepted_h()) || in.accepted_h() < 0.0 ||
      in.previous_accepted_h() < 0.0 || in.accepted_steps() < 0) {
    return "its coordinator's accepted_h, previous_accepted_h or accepted_steps is not a step length or count";
  }
  bool relaxation = false;  // (not restored if saved with other settings: it starts afresh, as they say)
  if (in.has_relaxation()) {
    if (std::string wrong = relaxation_.Restore(in.relaxation(), &relaxation); !wrong.empty()) {
      return "its coordinator's " + wrong;
    }
  }
  accepted_x_ = v[0];
  previous_accepted_x_ = v[1];
  lambda_start_ = v[2];
  filtered_start_ = v[3];
  accepted_position_ = v[4];
  accepted_velocity_ = v[5];
  accepted_acceleration_ = v[6];
  previous_accepted_position_ = v[7];
  previous_accepted_velocity_ = v[8];
  accepted_offset_ = v[9];
  for (size_t k = 0; k < points; ++k) {
    sensitivity_[k] = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(v[10].data() + 9 * k);
  }
  accepted_sensitivity_ = sensitivity_;
  accepted_steps_ = in.accepted_steps();
  accepted_h_ = in.accepted_h();
  previous_accepted_h_ = in.previous_accepted_h();
  offset_known_ = in.offset_known();
  for (size_t k = 0; k < points; ++k) was_contact_[k] = in.was_contact(static_cast<int>(k));
  restored_ = true;
  return {};
}

void Coordinator::StartReactionsFrom(const DaeState& state) {
  for (size_t k = 0; k < system_.interface_points.size(); ++k) {
    lambda_start_.segment<3>(3 * static_cast<Eigen::Index>(k)) =
        system_.InterfaceReaction(static_cast<int>(k), state.lambda);
  }
  filtered_start_ = lambda_start_;
}

void Coordinator::Handshake(const std::string& scenario_name, double start_time, double step) {
  // The start: accelerations with the coupling rows left out (free interface points, λ = 0),
  // a_0 = q̈_0 (a shifted start would impose end-of-step coordinates at the wrong time). A
  // settled start knows the nodes' motion (at rest, or turning with the rotor): its state, the
  // rows held, stands, and its multipliers are the first reactions the peers hold (without
  // them the blades sank 0.006° in the first steps before the reactions caught up).
  if (restored_) {
    // A restart that continues the run: CGα's history, the data (the imposed coordinates) and
    // this memory are the run's own at the saved step.
    x_ = applied_ = accepted_x_;
  } else if (settings_.settled_start) {
    // a_0 = q̈_0 as at a free start: the shifted start-up would take the first try's imposed
    // coordinates (end-of-step values) at t_0 + Δα h, and each try of the first step its own a_0.
    integrator_->Restart(integrator_->state());
    resting_at_start_ = true;  // (Impacts)
    StartReactionsFrom(integrator_->state());
    x_ = accepted_x_ = applied_ = lambda_start_;
  } else {
    std::vector<int> every_point(system_.interface_points.size());
    for (size_t k = 0; k < every_point.size(); ++k) every_point[k] = static_cast<int>(k);
    RestartWithCouplingRowsFree(integrator_->state(), start_time, every_point);
  }
  if (!restored_) {  // (a continued run's imposed coordinates are its own, restored with the data)
    for (size_t k = 0; k < system_.interface_points.size(); ++k) {
      const Eigen::Vector3d a =
          system_.interface_points[k].point.Rate(integrator_->state().qddot);  // point acceleration
      for (int j = 0; j < 3; ++j) data_->imposed[3 * k + static_cast<size_t>(j)].acceleration = a(j);
    }
  }
  for (Peer& peer : peers_) {
    auto* hello = peer.channel->Outgoing(-1, 0).mutable_hello();
    hello->set_scenario_name(scenario_name);
    hello->set_process_name(peer.channel->options().peer);
    for (int p : peer.points) hello->add_interface_nodes(system_.interface_points[static_cast<size_t>(p)].contact_node);
    hello->set_start_time(start_time);
    hello->set_step(step);
    if (!restored_) {
      // A settled start: where the settle left the nodes (it may move them). A free start: where
      // the tied points are and how they move in the consistent start, which the contact process
      // checks against its nodes' scenario state (Hello.settled).
      hello->set_settled(settings_.settled_start);
      for (int p : peer.points) {
        const LinearVector& point = system_.interface_points[static_cast<size_t>(p)].point;
        const Eigen::Vector3d x = point.Value(integrator_->state().q), v = point.Rate(integrator_->state().qdot);
        for (size_t j = 0; j < 3; ++j) {
          const ImposedCoordinate& c = data_->imposed[3 * static_cast<size_t>(p) + j];
          hello->add_node_positions(settings_.settled_start ? c.value : x(static_cast<Eigen::Index>(j)));
          hello->add_node_velocities(settings_.settled_start ? c.rate : v(static_cast<Eigen::Index>(j)));
        }
      }
    }
    for (const MovingObstacle& o : peer.obstacles) {
      hello->add_moving_obstacles(o.name);
      FillFrame(o.body, integrator_->state(), 0.0, hello->add_obstacle_frames());
    }
    peer.channel->Send();
  }
  jacobians_ = settings_.interface_jacobians && n_ > 0;
  for (Peer& peer : peers_) {
    const auto& welcome = peer.channel->Receive(Envelope::kWelcome, -1, -1).welcome();
    const std::string& name = peer.channel->options().peer;
    if (welcome.process_name() != name) {
      throw InputError("coupling: the Welcome from the process addressed as '" + name + "' names itself '" +
                       interface::EchoedText(welcome.process_name()) + "'; expected '" + name + "'");
    }
    if (welcome.interface_nodes_size() != static_cast<int>(peer.points.size())) {
      throw InputError("coupling: '" + name + "' welcomed " + std::to_string(welcome.interface_nodes_size()) +
                       " interface nodes, expected " + std::to_string(peer.points.size()));
    }
    // The same nodes in the same order: the k-th reaction goes to the k-th node named.
    for (int i = 0; i < welcome.interface_nodes_size(); ++i) {
      const std::string& asked =
          system_.interface_points[static_cast<size_t>(peer.points[static_cast<size_t>(i)])].contact_node;
      if (welcome.interface_nodes(i) != asked) {
        throw InputError("coupling: Welcome.interface_nodes[" + std::to_string(i) + "] from '" + name + "' is '" +
                         interface::EchoedText(welcome.interface_nodes(i)) + "'; the Hello asked for '" + asked +
                         "' there (the nodes, in the Hello's order)");
      }
    }
    peer.jacobians = welcome.interface_jacobians();
    jacobians_ = jacobians_ && peer.jacobians;
  }
  // The nodes' motion at the start (the first step's predicted positions). A free start's nodes
  // are where their points are (λ = 0); a settled start's where the settle left them, its
  // imposed coordinates: a point on a regularised tie is not its node, and the settled rod
  // resting on its stop had its node predicted cλ = 4.9e-7 m inside the stop (its point's
  // position) and its first step began from a pre-solve with the tie slack. A continued run
  // keeps its memory (overwritten here, a restart from the middle of a contact began from the
  // points' positions too).
  if (restored_) return;
  const DaeState& start = integrator_->state();
  for (size_t k = 0; k < system_.interface_points.size(); ++k) {
    const Eigen::Index o = 3 * static_cast<Eigen::Index>(k);
    const LinearVector& point = system_.interface_points[k].point;
    accepted_position_.segment<3>(o) = point.Value(start.q);
    accepted_velocity_.segment<3>(o) = point.Rate(start.qdot);
    accepted_acceleration_.segment<3>(o) = point.Rate(start.qddot);
    if (!settings_.settled_start) continue;
    for (int j = 0; j < 3; ++j) {
      const ImposedCoordinate& c = data_->imposed[3 * k + static_cast<size_t>(j)];
      accepted_position_(o + j) = c.value;
      accepted_velocity_(o + j) = c.rate;
    }
  }
}

void Coordinator::ReceiveKinematics(int iteration) {
  in_contact_ = false;
  std::fill(contact_.begin(), contact_.end(), false);
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
    if (k.in_contact_size() != 0 && k.in_contact_size() != static_cast<int>(peer.points.size())) {
      throw InputError("coupling: Kinematics.in_contact from '" + peer.channel->options().peer + "' has " +
                       std::to_string(k.in_contact_size()) + " values; expected one per interface node (" +
                       std::to_string(peer.points.size()) + ") or none");
    }
    for (int i = 0; i < k.in_contact_size(); ++i) {
      contact_[static_cast<size_t>(peer.points[static_cast<size_t>(i)])] = k.in_contact(i) != 0;
      in_contact_ = in_contact_ || k.in_contact(i) != 0;
    }
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
        applied_(v) = x_(v);  // (a peer that does not say held the force it was sent)
      }
    }
    if (!jacobians_) continue;
    // The force it held and its sensitivities (protocol 3): 3 and 9 per node, finite.
    auto check = [&](const char* field, int size, int want, bool optional,
                     const google::protobuf::RepeatedField<double>& values) {
      if (size == 0 && optional) return false;
      if (size != want) {
        throw InputError("coupling: Kinematics." + std::string(field) + " from '" + peer.channel->options().peer +
                         "' of step " + std::to_string(step_) + " has " + std::to_string(size) + " values; expected " +
                         std::to_string(want) + (optional ? " or none" : " (its Welcome offered interface Jacobians)"));
      }
      for (int i = 0; i < size; ++i) {
        if (!std::isfinite(values.Get(i))) {
          throw InputError("coupling: Kinematics." + std::string(field) + "[" + std::to_string(i) + "] from '" +
                           peer.channel->options().peer + "' of step " + std::to_string(step_) + " is " +
                           interface::FormatNumber(values.Get(i)) + "; expected a finite number");
        }
      }
      return true;
    };
    const int nodes = static_cast<int>(peer.points.size());
    const bool applied = check("applied_force", k.applied_force_size(), 3 * nodes, true, k.applied_force());
    check("position_sensitivity", k.position_sensitivity_size(), 9 * nodes, false, k.position_sensitivity());
    for (int i = 0; i < nodes; ++i) {
      const int p = peer.points[static_cast<size_t>(i)];
      if (applied) {
        for (int j = 0; j < 3; ++j) applied_(3 * p + j) = k.applied_force(3 * i + j);
      }
      sensitivity_[static_cast<size_t>(p)] = Block(k.position_sensitivity().data() + 9 * i);
    }
  }
}

void Coordinator::Impose(double h) {
  for (Eigen::Index v = 0; v < n_; ++v) data_->imposed[static_cast<size_t>(v)].value = position_(v);
  ImposeRates(h);
}

void Coordinator::ImposeRates(double h) {
  for (Eigen::Index v = 0; v < n_; ++v) {
    ImposedCoordinate& c = data_->imposed[static_cast<size_t>(v)];
    c.rate = velocity_(v);
    c.acceleration = (velocity_(v) - start_velocity_(v)) / h;
  }
}

int Coordinator::Step(double t, double h) { return StepOrSplit(t, h, 0); }

// A step the coupled solve cannot take (a CGα solve failed, or no convergence with
// stop_at_max_iterations) is rejected at every peer and redone as two halves, a half that fails
// as two quarters (StepStatus::kRetrySplits); only then does the run end, its message saying that smaller steps
// were tried. A fixed-step run's rows stay on its grid: the substeps end where the step ends.
int Coordinator::StepOrSplit(double t, double h, int depth) {
  const Attempt attempt = Try(t, h);
  if (attempt.converged() || (!attempt.failed() && !settings_.stop_at_max_iterations)) {
    if (!attempt.converged()) ++marked_;
    Accept(t, h);
    return attempt.iterations;
  }
  if (depth >= StepStatus::kRetrySplits) {
    std::string why = Describe(attempt);
    if (depth > 0) why = StepStatus::AfterRetries(why, 1 << depth, h, t);
    integrator_->Restore(start_);
    throw NumericalError(why);
  }
  Reject();
  ++retried_;
  const int first = StepOrSplit(t, 0.5 * h, depth + 1);
  return first + StepOrSplit(t + 0.5 * h, 0.5 * h, depth + 1);
}

std::string Coordinator::Describe(const Attempt& attempt) const {
  const std::string to = " the step to t = " + interface::FormatNumber(attempt.end_time) + " s";
  switch (attempt.outcome) {
    case Attempt::Outcome::kConverged:
      return "coupling: the step to t = " + interface::FormatNumber(attempt.end_time) + " s converged";
    case Attempt::Outcome::kNotConverged:
      return "coupling: no convergence in " + std::to_string(settings_.max_iterations) + " iterations at step " +
             std::to_string(step_) + " (t = " + interface::FormatNumber(attempt.end_time) + " s): reaction residual " +
             interface::FormatNumber(log_.back().reaction_residual) + " N, displacement change " +
             interface::FormatNumber(log_.back().displacement_change) + " m; " + CouplingState() +
             (jacobians_ ? "; raise coupling.iteration.max_iterations"
                         : "; raise coupling.iteration.max_iterations, choose another relaxation, or shorten the step");
    case Attempt::Outcome::kSmoothFailed: {
      const std::string why = attempt.smooth.Describe(integrator_->settings());
      if (!attempt.with_answers) return why;
      // The smooth step could not take the contact processes' answers: say which.
      return "coupling iteration " + std::to_string(attempt.failed_iteration) + " of" + to +
             ": the smooth step with the contact processes' answers failed (" + CouplingState() + "): " + why;
    }
    case Attempt::Outcome::kReactionsNotFinite:
      return "coupling: the smooth model's reactions on the interface nodes are not finite after coupling iteration " +
             std::to_string(attempt.failed_iteration) + " of" + to;
  }
  return {};
}

std::string Coordinator::CouplingState() const {
  // Which interface nodes are in contact (closing in this step or resting), and where the two
  // sides disagree most: the coupling's side of a failed step.
  // A contact that opened in the step (a lift-off, a rebound) is named too: "none in contact"
  // at the step of a rebound read as if nothing had happened.
  std::string contacts;
  for (size_t k = 0; k < contact_.size(); ++k) {
    if (!contact_[k] && !was_contact_[k]) continue;
    const char* what = !contact_[k]      ? " (opening in this step)"
                       : was_contact_[k] ? " (resting)"
                                         : " (closing in this step)";
    contacts +=
        (contacts.empty() ? "" : ", ") + std::string("'") + system_.interface_points[k].contact_node + "'" + what;
  }
  std::string worst;
  double largest = -1.0;
  for (size_t k = 0; k < system_.interface_points.size(); ++k) {
    const Eigen::Index o = 3 * static_cast<Eigen::Index>(k);
    const double d = (x_tilde_.segment<3>(o) - (jacobians_ ? applied_ : x_).segment<3>(o)).lpNorm<Eigen::Infinity>();
    if (d > largest) {
      largest = d;
      worst = "node '" + system_.interface_points[k].contact_node + "' (force " +
              interface::FormatNumber(x_tilde_.segment<3>(o).norm()) + " N, position " + "[" +
              interface::FormatNumber(position_(o)) + ", " + interface::FormatNumber(position_(o + 1)) + ", " +
              interface::FormatNumber(position_(o + 2)) + "] m)";
    }
  }
  return "interface nodes in contact: " +
         (contacts.empty() ? std::string("none, in this step and the last") : contacts) +
         (worst.empty() ? "" : "; largest force mismatch " + interface::FormatNumber(largest) + " N at " + worst);
}

void Coordinator::BeginStep(double t, double h, const DaeState& frames, double ahead) {
  for (size_t q = 0; q < peers_.size(); ++q) {
    Peer& peer = peers_[q];
    auto* begin = peer.channel->Outgoing(step_, 0).mutable_step_begin();  // (accepts a pending step)
    begin->set_time(t);
    begin->set_step(h);
    if (!moved_points_.empty()) FillRestartedNodes(peer, begin->mutable_restarted_nodes());
    FillReactions(q, frames, ahead, begin->mutable_predictor());
    peer.channel->Send();
  }
  moved_points_.clear();  // (told: the peers accepted the step with them)
  ReceiveKinematics(0);
}

void Coordinator::FillReactions(size_t q, const DaeState& frames, double ahead, coupling::Reactions* reactions) {
  const Peer& peer = peers_[q];
  sent_frames_[q].clear();
  for (const MovingObstacle& o : peer.obstacles) {
    sent_frames_[q].push_back(FillFrame(o.body, frames, ahead, reactions->add_obstacle_frames()));
  }
  for (int p : peer.points) {
    // This side's own numbers: a non-finite one is its numerical failure (exit 3), not a
    // message for the peer to refuse as bad input.
    const Eigen::Vector3d force = x_.segment<3>(3 * p);
    if (!force.allFinite() || (jacobians_ && !(stiffness_[static_cast<size_t>(p)].allFinite() &&
                                               sent_position_.segment<3>(3 * p).allFinite()))) {
      throw NumericalError("coupling: the reaction of interface node '" +
                           system_.interface_points[static_cast<size_t>(p)].contact_node + "' is not finite (force [" +
                           interface::FormatNumber(force(0)) + ", " + interface::FormatNumber(force(1)) + ", " +
                           interface::FormatNumber(force(2)) + "] N) in step " + std::to_string(step_) +
                           ": the smooth step has failed");
    }
    for (int j = 0; j < 3; ++j) reactions->add_force(force(j));
    if (!jacobians_) continue;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) reactions->add_stiffness(stiffness_[static_cast<size_t>(p)](r, c));
    }
    for (int j = 0; j < 3; ++j) reactions->add_position(sent_position_(3 * p + j));
  }
}

void Coordinator::Exchange(int iteration, const DaeState& frames) {
  for (size_t q = 0; q < peers_.size(); ++q) {
    Peer& peer = peers_[q];
    FillReactions(q, frames, 0.0, peer.channel->Outgoing(step_, iteration).mutable_reactions());
    peer.channel->Send();
  }
  ReceiveKinematics(iteration);
}

void Coordinator::ReactionsFromSolve() {
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
}

double Coordinator::ReactionPerMultiplier() const {
  // ∂x̃/∂λ₁ of the two forms above.
  if (!settings_.step_average_reaction) return 1.0;
  return integrator_->gamma() * (1.0 - integrator_->alpha_f()) / (1.0 - integrator_->alpha_m());
}

Eigen::Vector3d Coordinator::ReactionConstant(int point) const {
  if (!settings_.step_average_reaction) return Eigen::Vector3d::Zero();
  const Eigen::Index o = 3 * static_cast<Eigen::Index>(point);
  const double g = integrator_->gamma(), am = integrator_->alpha_m(), af = integrator_->alpha_f();
  return (1.0 - g) * filtered_start_.segment<3>(o) +
         g * (af * lambda_start_.segment<3>(o) - am * filtered_start_.segment<3>(o)) / (1.0 - am);
}

void Coordinator::ImposeModel(double h) {
  // k(x) = k̃ + S (x − x̃) with x = κ λ + x_c on the rows p(q) − k − cλ = 0 (Schweizer & Lu's
  // coupling through the constraint, with the peer's answer linearised: Kübler & Schiehlen).
  const double kappa = ReactionPerMultiplier();
  for (size_t k = 0; k < system_.interface_points.size(); ++k) {
    const Eigen::Index o = 3 * static_cast<Eigen::Index>(k);
    const Eigen::Matrix3d& S = sensitivity_[k];
    const Eigen::Vector3d value =
        position_.segment<3>(o) + S * (ReactionConstant(static_cast<int>(k)) - applied_.segment<3>(o));
    for (int j = 0; j < 3; ++j) data_->imposed[static_cast<size_t>(o + j)].value = value(j);
    data_->interface_compliance[k] = kappa * S;
  }
  ImposeRates(h);
}

void Coordinator::UpdateStiffness(double h) {
  // The smooth side's own response D = ∂λ/∂k (CgAlpha::InterfaceResponse: the peers' compliance
  // not in it; the other points held where they are), x = κλ + x_c.
  if (!integrator_->has_factorization()) return;
  const double kappa = ReactionPerMultiplier();
  const DaeState& state = integrator_->state();
  if (integrator_->factorizations() != response_factorizations_ || h != response_h_) {
    for (size_t k = 0; k < response_.size(); ++k) {
      response_[k] = kappa * integrator_->InterfaceResponse(static_cast<int>(k), h);
      if (!response_[k].allFinite()) response_[k].setZero();  // (no linearisation rather than a bad one)
      response_axes_[k] = BodyAxes(static_cast<int>(k), state);
    }
    response_factorizations_ = integrator_->factorizations();
    response_h_ = h;
  }
  // A reused matrix is some steps old: the stiffness turns with the body carrying the point (a
  // blade on a spinning hub: 0.56 rad over 20 reused steps of the Puma's), E = R E₀ Rᵀ with
  // R = F F₀ᵀ of its axes.
  for (size_t k = 0; k < response_.size(); ++k) {
    const Eigen::Matrix3d R = BodyAxes(static_cast<int>(k), state) * response_axes_[k].transpose();
    stiffness_[k] = R * response_[k] * R.transpose();
  }
}

Eigen::Matrix3d Coordinator::BodyAxes(int point, const DaeState& state) const {
  const int body = system_.interface_points[static_cast<size_t>(point)].body;
  return body < 0 ? Eigen::Matrix3d::Identity() : smooth::BodyAxes(state.q, body);
}

double Coordinator::FrameDrift(const DaeState& state) const {
  double drift = 0.0;
  for (size_t q = 0; q < peers_.size(); ++q) {
    for (size_t i = 0; i < peers_[q].obstacles.size(); ++i) {
      coupling::Frame frame;
      const auto [c, R] = FillFrame(peers_[q].obstacles[i].body, state, 0.0, &frame);
      const auto& [c0, R0] = sent_frames_[q][i];
      for (int p : peers_[q].points) {
        if (!contact_[static_cast<size_t>(p)]) continue;  // (a node off its planes does not feel them move)
        const Eigen::Vector3d k = position_.segment<3>(3 * p);
        drift = std::max(
            drift,
            ((c - c0) + (R * R0.transpose() - Eigen::Matrix3d::Identity()) * (k - c0)).lpNorm<Eigen::Infinity>());
      }
    }
  }
  return drift;
}

StepStatus Coordinator::SolveStep(double t, double h, const DaeState* guess) {
  if (guess != nullptr && !iterate_solved_) guess = nullptr;  // (the step's predictor instead)
  const StepStatus status = integrator_->TryStep(t, h, guess);
  if (!status.ok()) return status;
  newton_ += status.iterations;
  iterate_ = integrator_->state();  // equal sizes: no allocation once warm
  iterate_solved_ = true;
  ReactionsFromSolve();
  return status;
}

void Coordinator::Linearise(double t, double h) {
  // The nodes' positions predicted from the accepted steps (no acceleration after an impact)
  // and x_ (the reactions predicted); the smooth step solved with the peers' last affine answers
  // about them gives a point (x̂, k̂) of the smooth side's own response, and its matrix the
  // slope E: the peers then solve their contact problems for the linearised coupled pair.
  velocity_ = accepted_velocity_ + h * accepted_acceleration_;
  if (offset_known_ && SameStepLength(h, accepted_h_) && SameStepLength(h, previous_accepted_h_)) {
    // The peers' last law k = a_n + S x carried one step on: a_{n+1} = a_n + (k_n − k_{n−1}) +
    // h (v_n − v_{n−1}). For a free node under a constant force (Moreau–Jean, θ-method:
    // k_{n+1} = k_n + h v_n + S (f + x), S = h²θ/m) it is the law the peer will step with, exactly;
    // the pre-solve is then the coupled step, which the peers' answer confirms (LinearisationAgrees).
    // A node on its obstacle: second order in the obstacle's motion, as the Taylor predictor below.
    for (size_t k = 0; k < sensitivity_.size(); ++k) {
      const Eigen::Index o = 3 * static_cast<Eigen::Index>(k);
      position_.segment<3>(o) = accepted_offset_.segment<3>(o) +
                                (accepted_position_.segment<3>(o) - previous_accepted_position_.segment<3>(o)) +
                                h * (accepted_velocity_.segment<3>(o) - previous_accepted_velocity_.segment<3>(o)) +
                                sensitivity_[k] * x_.segment<3>(o);
    }
  } else {
    position_ = accepted_position_ + h * accepted_velocity_ + 0.5 * h * h * accepted_acceleration_;
  }
  applied_ = x_;
  integrator_->Restore(start_);
  ImposeModel(h);
  if (!SolveStep(t, h, nullptr).ok()) {
    // The predicted node positions with the last answers' compliance were more than CGα could
    // take (observed: the Puma gust at h = 2 ms, 6.638 s, a blade landing on its stop): the
    // predictions themselves (x_0, k_pred) serve as the linearisation point, with the last E.
    integrator_->Restore(start_);
    sent_position_ = position_;
    ++linearisation_fallbacks_;
    iterate_solved_ = false;  // (no solve of this step to start Newton from)
    return;
  }
  LineariseAtSolve(h);  // (applied_ = x_: the predictor's force)
}

void Coordinator::LineariseAtSolve(double h) {
  // The last smooth solve's force x* and the kinematics it assumed, k̃ + S (x* − x̃).
  for (size_t k = 0; k < sensitivity_.size(); ++k) {
    const Eigen::Index o = 3 * static_cast<Eigen::Index>(k);
    sent_position_.segment<3>(o) =
        position_.segment<3>(o) + sensitivity_[k] * (x_tilde_.segment<3>(o) - applied_.segment<3>(o));
  }
  x_ = x_tilde_;
  UpdateStiffness(h);
}

bool Coordinator::LinearisationAgrees(CouplingIterationRecord* record) const {
  // The pre-solve's force x̂ (x_) and kinematics k̂ (sent_position_) against the peers' answer:
  // the force they held x̃ (applied_) and their nodes' positions k̃ (position_). Within the
  // tolerances of JacobianConverged, both sides hold a solution of the coupled step: the smooth
  // side's with the interface at k̂, the peers' at k̃ under x̃ = x̂ + E (k̃ − k̂).
  record->reaction_residual = n_ > 0 ? (x_ - applied_).lpNorm<Eigen::Infinity>() : 0.0;
  double mismatch = FrameDrift(iterate_);
  for (size_t k = 0; k < sensitivity_.size(); ++k) {
    const Eigen::Index o = 3 * static_cast<Eigen::Index>(k);
    mismatch = std::max(mismatch, (position_.segment<3>(o) - sent_position_.segment<3>(o)).lpNorm<Eigen::Infinity>());
  }
  record->displacement_change = mismatch;
  return ForcesAgree(x_) && mismatch <= settings_.displacement_tolerance;
}

bool Coordinator::ForcesAgree(const Eigen::VectorXd& force) const {
  // Per node |x − x̃|∞ <= max(reaction_tolerance · max(1 N, |x|∞), ‖E‖ displacement_tolerance),
  // x̃ the force the peers held (applied_).
  const double scale = std::max(1.0, n_ > 0 ? force.lpNorm<Eigen::Infinity>() : 0.0);
  for (size_t k = 0; k < stiffness_.size(); ++k) {
    const Eigen::Index o = 3 * static_cast<Eigen::Index>(k);
    const double floor = stiffness_[k].cwiseAbs().rowwise().sum().maxCoeff() * settings_.displacement_tolerance;
    if ((force.segment<3>(o) - applied_.segment<3>(o)).lpNorm<Eigen::Infinity>() >
        std::max(settings_.reaction_tolerance * scale, floor)) {
      return false;
    }
  }
  return true;
}

bool Coordinator::JacobianConverged(CouplingIterationRecord* record) const {
  // The smooth step solved with the peers' answers as affine in the force; it agrees with them
  // once its force x* is the one they held (x̃) — then the kinematics it assumed, k̃ + S (x* − x̃),
  // are theirs — and the obstacles' frames are those they stepped with. A force mismatch below
  // what displacement_tolerance makes through the smooth side's own stiffness at the node
  // (‖E‖ displacement_tolerance: 0.2 N for a 2e8 N/m tie at 1e-9 m) is within the kinematic
  // tolerance: a node resting on its stop through a stiff tie has its force only to that (5e-15 m
  // of position round-off is 1e-6 N).
  record->reaction_residual = n_ > 0 ? (x_tilde_ - applied_).lpNorm<Eigen::Infinity>() : 0.0;
  double mismatch = FrameDrift(iterate_);
  for (size_t k = 0; k < sensitivity_.size(); ++k) {
    const Eigen::Index o = 3 * static_cast<Eigen::Index>(k);
    mismatch = std::max(
        mismatch, (sensitivity_[k] * (x_tilde_.segment<3>(o) - applied_.segment<3>(o))).lpNorm<Eigen::Infinity>());
  }
  record->displacement_change = mismatch;
  return ForcesAgree(x_tilde_) && mismatch <= settings_.displacement_tolerance;
}

bool Coordinator::RelaxationConverged(int iteration, bool free_flight, CouplingIterationRecord* record, bool* skipped) {
  const double scale = std::max(1.0, n_ > 0 ? x_tilde_.lpNorm<Eigen::Infinity>() : 0.0);
  record->reaction_residual = n_ > 0 ? (x_tilde_ - x_).lpNorm<Eigen::Infinity>() : 0.0;
  record->displacement_change = iteration == 0 ? std::numeric_limits<double>::infinity()
                                               : (position_ - previous_position_).lpNorm<Eigen::Infinity>();
  // Round-off: once the peers' kinematics no longer change beyond round-off, the smooth
  // side's answer x̃ cannot settle closer than its own jitter between the last two iterations
  // (a stiff tie turns 1e-17 m of position round-off into 1e-9 N of reaction): a residual
  // within that jitter passes, whatever the reaction tolerance asks.
  const double position_roundoff =
      64.0 * std::numeric_limits<double>::epsilon() * std::max(1.0, position_.lpNorm<Eigen::Infinity>());
  const bool at_roundoff = iteration > 0 && n_ > 0 && record->displacement_change <= position_roundoff &&
                           record->reaction_residual <= (x_tilde_ - previous_x_tilde_).lpNorm<Eigen::Infinity>();
  const bool within = record->reaction_residual <= settings_.reaction_tolerance * scale;
  bool converged =
      (within || at_roundoff) && (iteration > 0 ? record->displacement_change <= settings_.displacement_tolerance
                                                : record->reaction_residual == 0.0);
  // coupling.iteration.free_flight_margin: no contact can close within the step: the first
  // iteration is accepted if its reaction residual meets the tolerance, without the second
  // iteration that would confirm the kinematics (the displacement test).
  *skipped = iteration == 0 && !converged && free_flight && within;
  converged = converged || *skipped;
  if (converged && at_roundoff && !within) ++at_roundoff_;
  return converged;
}

// The step's start saved, and the predictor: the reactions extrapolated linearly from the last
// two accepted steps (constant after a start or an impact), scaled to this step's length. With a
// stiff tie the first residual is the prediction error times the tie's gain, so this is worth an
// iteration per step.
void Coordinator::BeginTry(double h) {
  iterate_solved_ = false;
  log_.clear();  // this step's records (the capacity stays: no allocation once warm)
  integrator_->SaveTo(&start_);
  for (Eigen::Index v = 0; v < n_; ++v) start_velocity_(v) = data_->imposed[static_cast<size_t>(v)].rate;
  relaxation_.BeginStep();
  const double ratio = accepted_h_ > 0.0 ? h / accepted_h_ : 1.0;
  x_ = accepted_steps_ >= 2 ? Eigen::VectorXd(accepted_x_ + ratio * (accepted_x_ - previous_accepted_x_)) : accepted_x_;
  newton_ = 0;
}

// This side failed in iteration `at` (every peer waits for its next message): the integrator back
// at the step's start; the caller rejects the step (adaptive) or ends the run.
Coordinator::Attempt Coordinator::Failed(int at, Attempt::Outcome outcome, Attempt result) {
  integrator_->Restore(start_);
  result.outcome = outcome;
  result.failed_iteration = at;
  result.iterations = at + 1;
  last_iteration_ = at;  // (the StepEnd that rejects it carries this iteration)
  return result;
}

// The step's coupling iterations ended with `last` (converged or not): what the caller needs.
Coordinator::Attempt Coordinator::Finished(int last, Attempt result) {
  last_iteration_ = last;
  result.iterations = last + 1;
  result.impact = !Impacts().empty();
  result.contact = in_contact_;
  result.time_to_contact = time_to_contact_;
  return result;
}

// The relaxation's update (IQN-ILS's above all, extrapolating secants of earlier steps) sent the
// peers reactions whose kinematics this side cannot solve (observed: the Puma gust's lift-off at
// 2.975 s: reactions that moved the node 32 m, Newton diverging to |q| ~ 1e158). Back-track from
// the last iteration that solved: first the plain relaxed update from it with the secants
// forgotten (the method's first-iteration ω), then halving towards it; ask the peers again.
// `backtracks`: this step's so far, this one included.
void Coordinator::Backtrack(int iteration, int backtracks) {
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
  Exchange(iteration + 1, iterate_);  // (position_ now the answer; previous_position_ stays the solved one's)
}

Coordinator::Attempt Coordinator::Try(double t, double h) {
  Attempt result;
  result.end_time = t + h;
  BeginTry(h);
  if (jacobians_) Linearise(t, h);
  // The moving obstacles' frames: the pre-solve's at the step's end; without one (no interface
  // Jacobians, or a pre-solve CGα could not take: iterate_ then holds an earlier step's solve, or
  // nothing in a run's first step) the start's advanced by h.
  if (iterate_solved_) {
    BeginStep(t, h, iterate_, 0.0);
  } else {
    BeginStep(t, h, integrator_->state(), h);
  }
  const bool free_flight = !jacobians_ && settings_.free_flight_margin > 0.0 && !in_contact_ &&
                           time_to_contact_ > settings_.free_flight_margin * h;
  int iteration = 0, backtracks = 0;
  if (jacobians_ && iterate_solved_ && settings_.accept_agreeing_linearisation) {
    CouplingIterationRecord record;
    record.step = step_;
    record.iteration = 0;
    if (LinearisationAgrees(&record)) {
      // The pre-solve stands (the integrator holds it): only the imposed rates, which the next
      // step starts from, become the peers' answer.
      ImposeRates(h);
      ++linearisation_accepted_;
      log_.push_back(record);
      return Finished(0, result);
    }
  }
  for (;; ++iteration) {
    integrator_->Restore(start_);  // (the imposed coordinates too: they are in the checkpoint's SystemData)
    if (jacobians_) {
      ImposeModel(h);
    } else {
      Impose(h);
    }
    const bool warm = jacobians_ || (settings_.warm_start && iteration > 0);
    result.smooth = SolveStep(t, h, warm ? &iterate_ : nullptr);
    if (!result.smooth.ok()) {
      // With interface Jacobians the smooth step could not take the contact processes' answers.
      result.with_answers = jacobians_;
      if (jacobians_) return Failed(iteration, Attempt::Outcome::kSmoothFailed, result);
      // The relaxation's update could not be solved: back-track (Backtrack), up to
      // kMaxBacktracks times a step, within max_iterations.
      if (iteration == 0 || backtracks >= kMaxBacktracks || iteration + 1 >= settings_.max_iterations) {
        return Failed(iteration, Attempt::Outcome::kSmoothFailed, result);
      }
      Backtrack(iteration, ++backtracks);
      continue;
    }
    solved_x_ = x_;
    if (!x_tilde_.allFinite()) {
      // (A huge but finite load gives infinite multipliers.) This side's failure, not a message
      // for the peers to refuse.
      return Failed(iteration, Attempt::Outcome::kReactionsNotFinite, result);
    }
    CouplingIterationRecord record;
    record.step = step_;
    record.iteration = iteration;
    bool skipped = false;
    const bool converged =
        jacobians_ ? JacobianConverged(&record) : RelaxationConverged(iteration, free_flight, &record, &skipped);
    result.outcome = converged ? Attempt::Outcome::kConverged : Attempt::Outcome::kNotConverged;
    if (skipped) {
      result.free_flight = true;
      ++free_flight_;
    }
    previous_x_tilde_ = x_tilde_;
    if (converged || iteration + 1 >= settings_.max_iterations) {
      record.relaxation_factor = 0.0;
      log_.push_back(record);
      break;
    }
    if (jacobians_) {
      LineariseAtSolve(h);
      record.relaxation_factor = 1.0;
    } else {
      relaxation_.Next(x_, x_tilde_, &x_next_);
      record.relaxation_factor = relaxation_.last_factor();
      x_ = x_next_;
    }
    log_.push_back(record);
    previous_position_ = position_;
    Exchange(iteration + 1, integrator_->state());
  }
  return Finished(iteration, result);
}

void Coordinator::Accept(double t, double h) {
  previous_accepted_x_ = accepted_x_;
  accepted_x_ = jacobians_ ? applied_ : x_;  // the force the peers held
  // The nodes' motion for the next step's prediction (no acceleration across an impact's jump).
  const std::vector<int> impacts = Impacts();
  accepted_acceleration_ = (velocity_ - accepted_velocity_) / h;
  for (int k : impacts) accepted_acceleration_.segment<3>(3 * k).setZero();
  // The peers' law of this step, k = a + S x (a = k̃ − S x̃), and the motion before it.
  previous_accepted_position_ = accepted_position_;
  previous_accepted_velocity_ = accepted_velocity_;
  previous_accepted_h_ = accepted_h_;
  offset_known_ = jacobians_ && accepted_steps_ >= 1 && impacts.empty();
  for (size_t k = 0; k < sensitivity_.size(); ++k) {
    const Eigen::Index o = 3 * static_cast<Eigen::Index>(k);
    accepted_offset_.segment<3>(o) = position_.segment<3>(o) - sensitivity_[k] * applied_.segment<3>(o);
  }
  accepted_position_ = position_;
  accepted_velocity_ = velocity_;
  accepted_h_ = h;
  accepted_sensitivity_ = sensitivity_;
  accepted_in_contact_ = in_contact_;
  accepted_time_to_contact_ = time_to_contact_;
  ++accepted_steps_;
  lambda_start_ = lambda_end_;
  filtered_start_ = filtered_end_;
  // A new contact (an impact): the points take their nodes' velocities and the history restarts,
  // unless the scenario keeps the smooth model going (restart_at_impact = false: a regularised
  // tie then carries the velocity jump over the next steps; scenario.proto).
  // The jump is taken by the rigid bodies alone (ProjectImpactVelocities: the beams' and hex27
  // bodies' velocities held), and only where they can take it: a point on a body clamped to a
  // beam (a pad on a beam blade's pitch fitting) is left to its tie, whose compliance passes the
  // jump into the blade over the next steps. Projected in the full mass metric, the jump of a
  // blade's cuff bent the beam's root within the step and the next step's position projection
  // diverged (|Φ| = inf: the first stop impact of generated articulated rotors with beam blades,
  // tests/data/rotors/); moving the whole blade as a rigid body with its cuff ran, but put the
  // Puma gust's blade 1 2.4° RMS off its continuous twin (0.074° when left to the tie): a blade
  // whose bending period is far longer than the impact does not take it as a rigid body. Rigid
  // blades need the restart: without it a regularised tie returns the impact's energy like a
  // spring (the small rotor's anti-flap impact at e = 0.5 rebounds at e ≈ 0.65, 0.5° into its stop).
  // Only the points whose node's contact closed in this step are freed: the rest of the model
  // (another blade resting on its stop) keeps its reactions and accelerations. Not a node of an
  // elastic body or a beam: projected in its consistent mass, the node's velocity jump spreads
  // over its neighbours with alternating signs, and Kelvin–Voigt damping turns that into
  // accelerations of 1e10 m/s² (observed: Newton, or the position projection, failed the step
  // after the first impact of tests/data/impacts/hex27_tip_on_stop.pbtxt and impacts/beam_tip_on_stop.pbtxt);
  // the body takes the jump through its own dynamics, the contact process's impulse having been
  // found with its stiffness E, and keeps the impulse out of its acceleration history
  // (HoldImpactingBodiesHistory).
  std::vector<int> restarted;
  for (int k : impacts) {
    if (!system_.interface_points[static_cast<size_t>(k)].elastic) restarted.push_back(k);
  }
  if (settings_.restart_at_impact && !impacts.empty()) {
    const DaeState before = integrator_->state();
    DaeState after = before;
    // The points move with their nodes across each impact's plane (along its reaction: Newton's
    // law's velocity); along the plane a node's velocity is its own, which on a stiff tie swings
    // about its point's (Moreau–Jean's midpoint rule does not damp it): imposed whole, it kicked
    // the blade in lag at each impact (generated rotor 648: 11 of 143 restarts failed the
    // projection's 10 % test, the pad's in-plane swing growing to 3 m/s).
    std::vector<Eigen::Vector3d>& normals = impact_normals_;
    normals.assign(system_.interface_points.size(), Eigen::Vector3d::Zero());
    for (int k : restarted) {
      const Eigen::Vector3d f = system_.InterfaceReaction(k, before.lambda);
      if (f.norm() > 0.0) normals[static_cast<size_t>(k)] = f.normalized();
    }
    if (!restarted.empty()) restarted = ProjectImpactVelocities(system_, *data_, t + h, restarted, normals, &after);
    if (!restarted.empty()) {
      // And onto their nodes' reported positions: the tie's stretch c·λ at the impact (0.25 mm
      // for 648's 139 N s) was a spring the next steps released into the node's swing, and the
      // step's point sat at the interface model's imposed value, which then differs from the
      // node's position (648: 0.11 mm along the plane). Not moved, the swing doubled at each
      // re-contact and rotor 639's pad went 0.107 m through its anti-flap plane (exit 3). (If a
      // solve of the move fails, the projection alone stands.)
      for (int k : restarted) {
        for (int j = 0; j < 3; ++j)
          data_->imposed[3 * static_cast<size_t>(k) + static_cast<size_t>(j)].value = position_(3 * k + j);
      }
      MoveImpactPointsOntoNodes(system_, *data_, t + h, restarted, normals, &after);
      MoveNodesWithRestart(before, after, restarted);  // (before the restart: it reads them)
      const Eigen::VectorXd a_before = integrator_->acceleration_variable();
      RestartWithCouplingRowsFree(std::move(after), t + h, restarted);
      KeepHistoryTheRestartDidNotChange(before, a_before);
      for (int k : restarted) accepted_x_.segment<3>(3 * k).setZero();  // the impact's reaction does not carry over
      accepted_steps_ = 0;
      offset_known_ = false;
      relaxation_.Forget();  // nor do the secants of the interface map before it
    }
    // (after a restart in the same step, whose consistent accelerations hold the impulse too)
    if (restarted.size() < impacts.size()) HoldImpactingBodiesHistory(impacts, restarted, t + h, h);
  }
  was_contact_ = contact_;
  resting_at_start_ = false;
  // Protocol 3: the next StepBegin accepts the step at the peers (or Shutdown's
  // last_accepted_step at the end): no StepEnd round trip.
  last_accepted_ = step_;
  ++step_;
}

void Coordinator::MoveNodesWithRestart(const DaeState& before, const DaeState& after,
                                       const std::vector<int>& restarted) {
  // The projection and the move changed the rigid bodies' velocities and positions, and with them
  // every interface point's on them; the nodes, the contact processes', kept theirs. On a stiff
  // tie Moreau–Jean's midpoint rule (θ = ½) does not damp a node's motion relative to its point
  // (the relative velocity changes sign each step, its amplitude kept), so the difference swung
  // for the rest of the run: a teetering yoke's other pad by ±0.13 m/s about its point 300 steps
  // after the first impact, and its own impact then reversed that swinging velocity, not the
  // yoke's (generated rotor 805: left to the tie, 21 ms on the plane, and no stop met after).
  // Each other node takes its point's jump and shift; its motion relative to its point is left as
  // it was: its own answered velocity (with interface Jacobians the imposed rates are the peers'
  // affine model's; sending those changed the relative motion too, and generated rotor 765
  // rebounded from its droop stop to −2.4° where its twin stayed on it). The impacting node keeps
  // its position (the point was moved onto it: moved to its point instead, a node resting on its
  // plane went into it by its tie's stretch at every closing, and a settled blade sank through
  // its stop, GeneratedRotors.ASettledPadSlidesAlongItsStopUntilItsTieHoldsIt) and takes its
  // point's new velocity: Newton's law's across the plane, the point's along it, so that no swing
  // about the point is left (generated rotor 648's bounce series on its anti-flap stop rebounded
  // at 1.19–1.40 times e = 0.704, each impact reversing the swing with the blade's approach).
  moved_points_.clear();
  for (size_t k = 0; k < system_.interface_points.size(); ++k) {
    const InterfacePoint& p = system_.interface_points[k];
    const Eigen::Index o = 3 * static_cast<Eigen::Index>(k);
    const bool impacting = std::find(restarted.begin(), restarted.end(), static_cast<int>(k)) != restarted.end();
    const Eigen::Vector3d jump = impacting ? Eigen::Vector3d(p.point.Rate(after.qdot) - velocity_.segment<3>(o))
                                           : Eigen::Vector3d(p.point.Rate(after.qdot) - p.point.Rate(before.qdot));
    const Eigen::Vector3d shift =
        impacting ? Eigen::Vector3d::Zero() : Eigen::Vector3d(p.point.Value(after.q) - p.point.Value(before.q));
    if (!impacting && jump.norm() < 1e-12 && shift.norm() < 1e-12) continue;  // (a body nothing moved: round-off)
    moved_points_.push_back(static_cast<int>(k));
    velocity_.segment<3>(o) += jump;
    position_.segment<3>(o) += shift;
    accepted_velocity_.segment<3>(o) = velocity_.segment<3>(o);
    accepted_position_.segment<3>(o) = position_.segment<3>(o);
    for (int j = 0; j < 3; ++j) {  // (rows as consistent as before)
      data_->imposed[3 * k + static_cast<size_t>(j)].rate += jump(j);
      data_->imposed[3 * k + static_cast<size_t>(j)].value += shift(j);
    }
  }
}

void Coordinator::KeepHistoryTheRestartDidNotChange(const DaeState& before, const Eigen::VectorXd& a_before) {
  // The restart's consistent accelerations are every body's, found with every node's imposed
  // acceleration, (v − v₀)/h, which holds the nodes' swing about their points divided by h. A body
  // whose velocities the restart did not change keeps its own history: reset, another blade
  // lifting off its droop stop took −0.03 rad/s in the next step with no contact of its own and
  // chattered on the stop every 9 ms (generated rotor 651, blade 1). Per rigid body (a beam's
  // node included), per coordinate of a hex27 body. Unchanged: by at most 1e-3 of the largest
  // change of any coordinate. The solves' round-off on a body the impulse does not reach (another
  // blade on a driven hub) is up to 1e-8 of it, the impacting blade's bodies change by 0.4–1
  // (generated rotor 648); a bound within the round-off's range (1e-12 absolute, 1e-9 relative)
  // fell on either side of it in a run and in its restart from a saved state, which departed
  // from the run made in one go by up to 0.29° (rotors 600, 648, 651, 780).
  const DaeState& now = integrator_->state();
  const double dv = (now.qdot - before.qdot).lpNorm<Eigen::Infinity>(),
               dq = (now.q - before.q).lpNorm<Eigen::Infinity>();
  held_a_ = integrator_->acceleration_variable();
  held_qddot_ = now.qddot;
  const Eigen::Index n = system_.coordinates;
  const Eigen::Index rigid = system_.elastic_offset.empty() ? n : system_.elastic_offset.front();
  bool kept = false;
  for (Eigen::Index o = 0; o < n;) {
    const Eigen::Index count = o < rigid ? kCoordinatesPerBody : 1;
    if ((now.qdot.segment(o, count) - before.qdot.segment(o, count)).lpNorm<Eigen::Infinity>() <= 1e-3 * dv &&
        (now.q.segment(o, count) - before.q.segment(o, count)).lpNorm<Eigen::Infinity>() <= 1e-3 * dq) {
      held_a_.segment(o, count) = a_before.segment(o, count);
      held_qddot_.segment(o, count) = before.qddot.segment(o, count);
      kept = true;
    }
    o += count;
  }
  if (kept) integrator_->ReplaceAccelerationHistory(held_a_, held_qddot_);
}

void Coordinator::FillRestartedNodes(const Peer& peer, coupling::RestartedNodes* out) const {
  // (The accepted kinematics: the next step's prediction has overwritten position_ and velocity_
  // by the time its StepBegin goes.)
  for (size_t i = 0; i < peer.points.size(); ++i) {
    const int k = peer.points[i];
    if (std::find(moved_points_.begin(), moved_points_.end(), k) == moved_points_.end()) continue;
    out->add_node(static_cast<int>(i));
    for (int j = 0; j < 3; ++j) out->add_position(accepted_position_(3 * k + j));
    for (int j = 0; j < 3; ++j) out->add_velocity(accepted_velocity_(3 * k + j));
  }
}

void Coordinator::HoldImpactingBodiesHistory(const std::vector<int>& impacts, const std::vector<int>& restarted,
                                             double t, double h) {
  // An impact left to its tie (an elastic node's; restart_at_impact restarts the rigid bodies'):
  // the impulse reached the smooth model within the step through the tie's multiplier, and the
  // step's a_{n+1} and q̈_{n+1} hold it divided by h on the bodies it moved. Carried on by
  // Eq. (3) and by Newmark's (1 − γ) h a_n and h² (½ − β) a_n, it pushed the blade on after its
  // rebound at every impact: a light pad on a beam node rattling between its stops gained energy
  // until the step failed (generated hingeless rotors 353, 383 and 458: exit 3) or the pad went
  // through its stop (551); a pad on an articulated blade's cuff (a rigid body the restart cannot
  // move: the beam clamped beyond it) likewise (801: the position projection diverged at 1.18 s).
  // The nonsmooth generalised-α keeps impulses out of the recurrence (Chen, Acary, Virlez &
  // Brüls, IJNME 96:487–511, 2013); here those bodies' history is the step before's, its last
  // impulse-free one, turned with each body over the step, and their positions, velocities and
  // multipliers the step's own. Only those bodies': held for every body, the other blades'
  // centripetal accelerations, turned by Ωh since, kicked them at each impact (generated rotor
  // 707, 116 rad/s: exit 3 at 0.86 s); the step's linearising pre-solve as the impulse-free
  // history let pads through their stops (seeds 2, 5 and 722). docs/design.md, "Impacts and the
  // restart".
  std::vector<bool> held(static_cast<size_t>(system_.coordinates), false);
  std::vector<int> turned;
  for (int k : impacts) {
    if (std::find(restarted.begin(), restarted.end(), k) != restarted.end()) continue;
    for (int b : BodiesTheImpulseMovedInTheStep(k, t, h)) {
      turned.push_back(b);
      for (int j = 0; j < kCoordinatesPerBody; ++j) held[static_cast<size_t>(kCoordinatesPerBody * b + j)] = true;
    }
    const InterfacePoint& p = system_.interface_points[static_cast<size_t>(k)];
    for (size_t e = 0; e < system_.elastic.size(); ++e) {  // a hex27 body's node: the body's
      const int first = system_.elastic_offset[e], count = 3 * system_.elastic[e]->body.node_count();
      const bool on = std::any_of(p.point.terms.begin(), p.point.terms.end(), [&](const LinearVector::Term& term) {
        return term.offset >= first && term.offset < first + count;
      });
      for (int j = 0; on && j < count; ++j) held[static_cast<size_t>(first + j)] = true;
    }
  }
  if (std::find(held.begin(), held.end(), true) == held.end()) return;
  held_a_ = integrator_->acceleration_variable();  // (equal sizes: no allocation once warm)
  held_qddot_ = integrator_->state().qddot;
  for (size_t i = 0; i < held.size(); ++i) {
    if (!held[i]) continue;
    held_a_(static_cast<Eigen::Index>(i)) = start_.a(static_cast<Eigen::Index>(i));
    held_qddot_(static_cast<Eigen::Index>(i)) = start_.state.qddot(static_cast<Eigen::Index>(i));
  }
  for (int b : turned) {
    // Each [x, u, v, w] block of the step before's accelerations turned by the body's rotation
    // over the step, E_{n+1} E_n⁻¹: a blade spinning at Ω has turned by Ωh, and its centripetal
    // accelerations with it (held unturned, they kick the blade by Ω²·Ωh at every impact).
    const Eigen::Index o = static_cast<Eigen::Index>(kCoordinatesPerBody) * b;
    Eigen::Matrix3d e0, e1;
    for (int c = 0; c < 3; ++c) {
      e0.col(c) = start_.state.q.segment<3>(o + 3 + 3 * c);
      e1.col(c) = integrator_->state().q.segment<3>(o + 3 + 3 * c);
    }
    const Eigen::Matrix3d turn = e1 * e0.inverse();
    for (int c = 0; c < 4; ++c) {
      held_a_.segment<3>(o + 3 * c) = turn * start_.a.segment<3>(o + 3 * c);
      held_qddot_.segment<3>(o + 3 * c) = turn * start_.state.qddot.segment<3>(o + 3 * c);
    }
  }
  integrator_->ReplaceAccelerationHistory(held_a_, held_qddot_);
  ++impacts_held_;
}

std::vector<int> Coordinator::BodiesTheImpulseMovedInTheStep(int k, double t, double h) const {
  // The bodies an impulse at point k moves at once through the constraints (for a beam's node,
  // its body), each beam among them with all its nodes; none if the tie did not deliver the
  // impulse within the step: its half period π √(m c) on the effective mass m the point's
  // reaction meets is longer than h. Such a tie is a spring the impact compresses over several
  // steps, and its force a real one of each: held, a two-blade teetering rotor's yoke (m = 240 kg
  // at the pad, c = 9.2e-9 m/N: 4.7 ms) pressed onto its stop by a gust bounced on it for 0.8 s
  // where its twin rested after one bounce (generated rotor 679; 646: exit 3). An articulated
  // cuff's pad (801: 1.3 kg, 1.1e-9 m/N, 0.12 ms) and a hingeless beam node's are held.
  const InterfacePoint& p = system_.interface_points[static_cast<size_t>(k)];
  if (p.body < 0) return {};  // (a hex27 node: HoldImpactingBodiesHistory holds its body)
  const auto beam_of = [&](int b) -> const std::vector<int>* {
    for (const std::vector<int>& nodes : system_.beam_node_bodies) {
      if (std::find(nodes.begin(), nodes.end(), b) != nodes.end()) return &nodes;
    }
    return nullptr;
  };
  Eigen::Matrix3d mobility = Eigen::Matrix3d::Zero();  // point velocity per unit impulse
  std::vector<int> moved = BodiesAnImpulseMoves(system_, *data_, t, integrator_->state().q, k, &mobility);
  if (beam_of(p.body) != nullptr) moved = {p.body};
  const Eigen::Vector3d force = system_.InterfaceReaction(k, integrator_->state().lambda);
  if (force.norm() == 0.0) return {};
  const Eigen::Vector3d n = force.normalized();
  const double mass = 1.0 / n.dot(mobility * n);
  if (!(M_PI * std::sqrt(mass * p.regularization) < h)) return {};
  std::vector<int> out;
  for (int b : moved) {
    const std::vector<int>* beam = beam_of(b);
    for (int c : beam != nullptr ? *beam : std::vector<int>{b}) {
      if (std::find(out.begin(), out.end(), c) == out.end()) out.push_back(c);
    }
  }
  return out;
}

std::vector<int> Coordinator::Impacts() const {
  // A settled start's first step closes no contact: its nodes rest on their stops (the settle's
  // equilibrium, no approach speed), and their contacts, reported closed in that step, are not
  // impacts. Restarted there, a rod settled on its stop lost 79 % of its pad's steady impulse and
  // a settled rotor's blade rose 0.023° off its droop stop (the tie's static stretch moved away).
  if (resting_at_start_) return {};
  std::vector<int> points;
  for (size_t k = 0; k < contact_.size(); ++k) {
    if (contact_[k] && !was_contact_[k]) points.push_back(static_cast<int>(k));
  }
  return points;
}

void Coordinator::Reject() {
  integrator_->Restore(start_);
  // A rejected step leaves no trace: its answers (the sensitivities of a step of another length,
  // h²θ/m for a free node; its contact flags) are not the accepted state's, and the next try
  // starts from the accepted ones, as a run taking that step from the start would.
  sensitivity_ = accepted_sensitivity_;
  in_contact_ = accepted_in_contact_;
  time_to_contact_ = accepted_time_to_contact_;
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
    stop->set_last_accepted_step(last_accepted_);
    if (!moved_points_.empty()) FillRestartedNodes(peer, stop->mutable_restarted_nodes());
    peer.channel->Send();
  }
  if (!wait_for_replies) return;
  for (Peer& peer : peers_) {
    if (!peer.channel->peer_stopped()) peer.channel->Receive(Envelope::kShutdown, -1, -1);
  }
}

}  // namespace cosim::smooth
