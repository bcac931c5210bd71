#include "nonsmooth_solver/coupling/contact_server.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <set>

#include "interface/base/errors.h"
#include "interface/scenario/checks.h"

namespace cosim::nonsmooth {

using coupling::Envelope;

namespace {

// The three values of a per-node vector field from index `at` (Hello's and RestartedNodes').
Eigen::Vector3d Triple(const google::protobuf::RepeatedField<double>& values, int at) {
  return {values.Get(at), values.Get(at + 1), values.Get(at + 2)};
}

}  // namespace

ContactServer::ContactServer(ContactStepper* simulation, interface::Channel* channel, std::string scenario_name)
    : simulation_(simulation), channel_(channel), scenario_name_(std::move(scenario_name)) {
  external_ = Eigen::VectorXd::Zero(3 * static_cast<Eigen::Index>(simulation_->model().nodes.size()));
}

void ContactServer::Answer(const Envelope& e) {
  const coupling::Hello& hello = e.hello();
  const std::string peer = channel_->options().peer;
  if (hello.scenario_name() != scenario_name_) {
    throw InputError("coupling: '" + peer + "' runs scenario '" + interface::EchoedText(hello.scenario_name()) +
                     "', this process read '" + scenario_name_ + "'; both sides must read the same scenario");
  }
  const auto& model_nodes = simulation_->model().nodes;
  nodes_.clear();
  if (hello.interface_nodes_size() == 0) {
    throw InputError("coupling: Hello from '" + peer + "' names no interface node; expected at least one");
  }
  for (int i = 0; i < hello.interface_nodes_size(); ++i) {
    const std::string& name = hello.interface_nodes(i);
    int found = -1;
    for (size_t n = 0; n < model_nodes.size(); ++n) {
      if (model_nodes[n].name == name) found = static_cast<int>(n);
    }
    if (found < 0) {
      std::string known;
      for (const auto& n : model_nodes) known += (known.empty() ? "" : ", ") + n.name;
      throw InputError("coupling: Hello.interface_nodes[" + std::to_string(i) + "] from '" + peer +
                       "' names contact node '" + interface::EchoedText(name) +
                       "', which this process does not have; known: " + known);
    }
    if (std::find(nodes_.begin(), nodes_.end(), found) != nodes_.end()) {
      throw InputError("coupling: Hello.interface_nodes[" + std::to_string(i) + "] from '" + peer +
                       "' names contact node '" + name + "' a second time; expected each node once");
    }
    nodes_.push_back(found);
  }
  if (!(hello.step() > 0.0) || !std::isfinite(hello.step())) {
    throw InputError("coupling: Hello.step from '" + peer + "' is " + interface::FormatNumber(hello.step()) +
                     "; expected a positive, finite step [s]");
  }
  if (!std::isfinite(hello.start_time())) {
    throw InputError("coupling: Hello.start_time from '" + peer + "' is " +
                     interface::FormatNumber(hello.start_time()) + "; expected a finite time [s]");
  }
  // Obstacles attached to smooth bodies: the Hello lists them with their start frames, in
  // which their scenario geometry (global, at the start) becomes fixed (a restart keeps the
  // geometry its first run fixed).
  std::map<std::string, const Obstacle*> needed;  // the body-attached obstacles this process's nodes touch
  for (const Contact& c : simulation_->model().contacts) {
    const Obstacle& o = simulation_->model().obstacles[static_cast<size_t>(c.obstacle)];
    if (o.driven >= 0) needed[o.name] = &o;
  }
  if (hello.obstacle_frames_size() != hello.moving_obstacles_size()) {
    throw InputError("coupling: Hello from '" + peer + "' lists " + std::to_string(hello.moving_obstacles_size()) +
                     " moving obstacles and " + std::to_string(hello.obstacle_frames_size()) +
                     " frames; expected one frame per obstacle");
  }
  moving_.clear();
  for (int i = 0; i < hello.moving_obstacles_size(); ++i) {
    const std::string& name = hello.moving_obstacles(i);
    const auto it = needed.find(name);
    if (it == needed.end()) {
      throw InputError(
          "coupling: Hello.moving_obstacles[" + std::to_string(i) + "] from '" + peer + "' is '" + name +
          "', which is not an obstacle attached to a body that this process's nodes touch (or is listed twice)");
    }
    const Obstacle& found = *it->second;
    needed.erase(it);
    DrivenFrame& d = simulation_->mutable_data()->frames[static_cast<size_t>(found.driven)];
    d.StartAt(ReadFrame(hello.obstacle_frames(i), "Hello.obstacle_frames[" + std::to_string(i) + "]"),
              hello.start_time());
    if (!keep_attached_geometry_) d.FixPlane(found.point, found.normal, found.tangent);
    moving_.push_back(found.driven);
  }
  if (!needed.empty()) {
    throw InputError("coupling: Hello from '" + peer + "' gives no frame for obstacle '" + needed.begin()->first +
                     "', attached to body '" + needed.begin()->second->driven_body + "'");
  }
  // A settled start's nodes, where the smooth side's settle left them.
  if (hello.node_positions_size() != 0 || hello.node_velocities_size() != 0) {
    const int expected = 3 * hello.interface_nodes_size();
    if (hello.node_positions_size() != expected || hello.node_velocities_size() != expected) {
      throw InputError("coupling: Hello from '" + peer + "' gives " + std::to_string(hello.node_positions_size()) +
                       " node positions and " + std::to_string(hello.node_velocities_size()) +
                       " node velocities; expected " + std::to_string(expected) +
                       " of each (3 per interface node) or none");
    }
    for (int i = 0; i < expected; ++i) {
      if (!std::isfinite(hello.node_positions(i)) || !std::isfinite(hello.node_velocities(i))) {
        throw InputError("coupling: Hello from '" + peer + "' gives a non-finite start for node '" +
                         hello.interface_nodes(i / 3) + "' (node_positions[" + std::to_string(i) + "] = " +
                         interface::FormatNumber(hello.node_positions(i)) + ", node_velocities[" + std::to_string(i) +
                         "] = " + interface::FormatNumber(hello.node_velocities(i)) + "); expected finite numbers");
      }
    }
    for (size_t k = 0; k < nodes_.size(); ++k) {
      const int at = 3 * static_cast<int>(k);
      const Eigen::Vector3d x = Triple(hello.node_positions(), at), v = Triple(hello.node_velocities(), at);
      if (!hello.settled()) RequireNodeAtItsPoint(static_cast<int>(k), x, v);
      simulation_->StartNodeAt(nodes_[k], x, v);
    }
  }
  accepted_time_ = hello.start_time();
  simulation_->SaveStart();
  coupling::Welcome* welcome = channel_->Outgoing(-1, 0).mutable_welcome();
  welcome->set_process_name(channel_->options().self);
  welcome->set_solver(simulation_->SolverName());
  for (const auto& name : hello.interface_nodes()) welcome->add_interface_nodes(name);
  jacobians_ = simulation_->SupportsInterfaceJacobians();
  if (jacobians_) simulation_->EnableInterfaceJacobians();
  welcome->set_interface_jacobians(jacobians_);
  channel_->Send();
}

void ContactServer::TentativeStep(int64_t step, int iteration) {
  simulation_->RestoreStart();  // (the nodes' state: the frames SetReactions gave stay this try's)
  simulation_->SetExternalForces(external_);
  if (jacobians_) simulation_->SetInterfaceStiffness(stiffness_, reference_);
  try {
    simulation_->StepTentatively(t_, h_);
  } catch (const Error& e) {
    StopOnFailure(e, step, iteration);
    throw;
  }
  ++tentative_;
  coupling::Kinematics* k = channel_->Outgoing(step, iteration).mutable_kinematics();
  const Eigen::VectorXd& q = simulation_->positions();
  const Eigen::VectorXd& v = simulation_->velocities();
  for (int node : nodes_) {
    for (int i = 0; i < 3; ++i) {
      k->add_position(q(3 * node + i));
      k->add_velocity(v(3 * node + i));
    }
    k->add_in_contact(simulation_->Impact(node) ? 1 : 0);
  }
  if (jacobians_) {
    const Eigen::VectorXd* applied = simulation_->AppliedForces();
    const bool sensitive = simulation_->Sensitivities(h_, &sensitivity_position_, &sensitivity_velocity_);
    for (int node : nodes_) {
      if (applied != nullptr) {
        for (int i = 0; i < 3; ++i) k->add_applied_force((*applied)(3 * node + i));
      }
      if (sensitive) {
        for (int i = 0; i < 9; ++i) {
          k->add_position_sensitivity(sensitivity_position_(9 * node + i));
          k->add_velocity_sensitivity(sensitivity_velocity_(9 * node + i));
        }
      }
    }
  }
  k->set_time_to_contact(simulation_->TimeToContact(resting_speed_));
  channel_->Send();
}

void ContactServer::StopOnFailure(const Error& e, int64_t step, int iteration) {
  auto* stop = channel_->Outgoing(step, iteration).mutable_shutdown();
  stop->set_exit_code(static_cast<int>(e.code()));
  stop->set_reason(e.what());
  channel_->Send();
}

BodyFrame ContactServer::ReadFrame(const coupling::Frame& frame, const std::string& where) const {
  const std::string peer = channel_->options().peer;
  auto check = [&](const char* field, int size, int expected) {
    if (size != expected) {
      throw InputError("coupling: " + where + "." + field + " from '" + peer + "' has " + std::to_string(size) +
                       " values; expected " + std::to_string(expected));
    }
  };
  check("position", frame.position_size(), 3);
  check("rotation", frame.rotation_size(), 9);
  check("velocity", frame.velocity_size(), 3);
  check("angular_velocity", frame.angular_velocity_size(), 3);
  BodyFrame f;
  for (int i = 0; i < 3; ++i) {
    f.origin(i) = frame.position(i);
    f.velocity(i) = frame.velocity(i);
    f.angular_velocity(i) = frame.angular_velocity(i);
    for (int j = 0; j < 3; ++j) f.rotation(i, j) = frame.rotation(3 * i + j);
  }
  const double orthogonality = (f.rotation.transpose() * f.rotation - Eigen::Matrix3d::Identity()).norm();
  if (!f.origin.allFinite() || !f.velocity.allFinite() || !f.angular_velocity.allFinite() || !(orthogonality < 1e-6) ||
      !(f.rotation.determinant() > 0.0)) {
    throw InputError("coupling: " + where + " from '" + peer +
                     "' is not a frame (finite origin and rates, a proper rotation matrix; |RᵀR − I| = " +
                     interface::FormatNumber(orthogonality) + ")");
  }
  return f;
}

void ContactServer::SetReactions(const coupling::Reactions& reactions, const char* where) {
  if (reactions.obstacle_frames_size() != static_cast<int>(moving_.size())) {
    throw InputError(std::string("coupling: ") + where + ".obstacle_frames from '" + channel_->options().peer +
                     "' has " + std::to_string(reactions.obstacle_frames_size()) + " frames; expected " +
                     std::to_string(moving_.size()) + ", one per moving obstacle");
  }
  for (size_t i = 0; i < moving_.size(); ++i) {
    Frame(i).SetEnd(ReadFrame(reactions.obstacle_frames(static_cast<int>(i)),
                              std::string(where) + ".obstacle_frames[" + std::to_string(i) + "]"));
  }
  const auto& force = reactions.force();
  if (force.size() != 3 * static_cast<int>(nodes_.size())) {
    throw InputError(std::string("coupling: ") + where + ".force from '" + channel_->options().peer + "' has " +
                     std::to_string(force.size()) + " values; expected 3 per interface node, " +
                     std::to_string(3 * nodes_.size()));
  }
  for (size_t n = 0; n < nodes_.size(); ++n) {
    for (int i = 0; i < 3; ++i) {
      const double f = force.Get(3 * static_cast<int>(n) + i);
      if (!std::isfinite(f)) {
        throw InputError(std::string("coupling: ") + where + ".force[" +
                         std::to_string(3 * n + static_cast<size_t>(i)) + "] from '" + channel_->options().peer +
                         "' is " + interface::FormatNumber(f) + "; expected a finite force [N]");
      }
      external_(3 * nodes_[n] + i) = f;
    }
  }
  // The smooth side's linearisation (protocol 3): both vectors or neither, every value finite.
  const int nodes = static_cast<int>(nodes_.size());
  if (reactions.stiffness_size() == 0 && reactions.position_size() == 0) {
    stiffness_.resize(0);
    reference_.resize(0);
    return;
  }
  auto refuse = [&](const std::string& what) {
    throw InputError(std::string("coupling: ") + where + " from '" + channel_->options().peer + "' " + what);
  };
  if (reactions.stiffness_size() != 9 * nodes || reactions.position_size() != 3 * nodes) {
    refuse("has " + std::to_string(reactions.stiffness_size()) + " stiffness and " +
           std::to_string(reactions.position_size()) + " position values; expected 9 and 3 per interface node (" +
           std::to_string(9 * nodes) + " and " + std::to_string(3 * nodes) + "), or none of either");
  }
  const Eigen::Index model_nodes = external_.size() / 3;
  stiffness_ = Eigen::VectorXd::Zero(9 * model_nodes);
  reference_ = Eigen::VectorXd::Zero(3 * model_nodes);
  // `per` values of each interface node into its model node's place in `out`, each finite.
  auto copy = [&](const google::protobuf::RepeatedField<double>& in, int per, const char* field, const char* unit,
                  Eigen::VectorXd* out) {
    for (int n = 0; n < nodes; ++n) {
      for (int i = 0; i < per; ++i) {
        const double v = in.Get(per * n + i);
        if (!std::isfinite(v)) {
          refuse(std::string(".") + field + "[" + std::to_string(per * n + i) + "] is " + interface::FormatNumber(v) +
                 "; expected a finite number [" + unit + "]");
        }
        (*out)(per * nodes_[static_cast<size_t>(n)] + i) = v;
      }
    }
  };
  copy(reactions.stiffness(), 9, "stiffness", "N/m", &stiffness_);
  copy(reactions.position(), 3, "position", "m", &reference_);
}

void ContactServer::Handshake() {
  // Under the launcher the Hello is awaited as long as it takes (the coordinator may build a
  // large model first; the launcher stops this process if the coordinator ends); started by
  // hand, for coupling.timeout.
  const char* supervised = std::getenv(interface::kSupervisedVariable);
  const bool wait = supervised != nullptr && std::string(supervised) == "1";
  Answer(channel_->Receive(Envelope::kHello, -1, -1,
                           wait ? std::numeric_limits<double>::infinity() : channel_->options().timeout));
}

void ContactServer::Run() {
  Handshake();
  ServeShutdown();  // every message up to the coordinator's Shutdown
}

const Envelope& ContactServer::Next() {
  replaying_deferred_ = has_deferred_;
  if (has_deferred_) {
    has_deferred_ = false;
    return deferred_;
  }
  return channel_->ReceiveAny();
}

void ContactServer::ServeStep(int64_t step, double t, double h) {
  // The coordinator takes the grid step whole or, when its coupled solve cannot, rejects it and
  // takes it as halves or quarters (Coordinator::StepOrSplit): served until the step's end is
  // accepted. Each step begins where the last accepted one ended, h / 2^k long (k <= 2).
  const double end = t + h, eps = 1e-9 * std::max(1.0, std::abs(end));
  while (accepted_time_ < end - eps) {
    const Envelope& e = Next();
    // (A StepBegin that accepts the step under way is checked when it begins its own.)
    if (e.has_step_begin() && step_ < 0) {
      const double from = e.step_begin().time(), length = e.step_begin().step();
      bool substep = false;
      for (int k = 0; k <= 2 && !substep; ++k) {
        substep = std::abs(length - h / (1 << k)) <= 1e-12 * std::max(1.0, h);  // (NaN fails)
      }
      if (!substep || !(std::abs(from - accepted_time_) <= eps) || !(from + length <= end + eps)) {
        throw InputError("coupling: StepBegin of step " + std::to_string(e.step()) +
                         " at t = " + interface::FormatNumber(from) + " s, h = " + interface::FormatNumber(length) +
                         " s from '" + channel_->options().peer + "', expected step " + std::to_string(step) +
                         " at t = " + interface::FormatNumber(t) + " s, h = " + interface::FormatNumber(h) +
                         " s (or its halves or quarters): both sides must read the same numerics");
      }
    }
    if (Handle(e) == Outcome::kShutdown) ThrowStopped("step " + std::to_string(step));
  }
}

void ContactServer::ThrowStopped(const std::string& before) const {
  // The coordinator stopped the run: this process ends with the run's outcome (its exit code
  // when it is one of the contract's failures, else a peer failure).
  const int code = coordinator_exit_code_;
  ThrowAs(PeerOutcome(code), "coupling: '" + channel_->options().peer + "' ended the run before " + before +
                                 " (exit code " + std::to_string(code) +
                                 (coordinator_reason_.empty() ? "" : ": " + coordinator_reason_) + ")");
}

void ContactServer::ServeUntil(double time) {
  const double eps = 1e-12 * std::max(1.0, std::abs(time));
  while (accepted_time_ < time - eps) {
    const Envelope& e = Next();
    if (e.has_step_begin() && step_ < 0 &&
        !(std::abs(e.step_begin().time() - accepted_time_) <= 1e-12 * std::max(1.0, std::abs(accepted_time_)))) {
      throw InputError(
          "coupling: StepBegin of step " + std::to_string(e.step()) +
          " at t = " + interface::FormatNumber(e.step_begin().time()) + " s from '" + channel_->options().peer +
          "', expected a step from the last accepted one's end, t = " + interface::FormatNumber(accepted_time_) + " s");
    }
    if (Handle(e) == Outcome::kShutdown) ThrowStopped("t = " + interface::FormatNumber(time) + " s");
  }
}

void ContactServer::ServeShutdown() {
  while (Handle(Next()) != Outcome::kShutdown) {
  }
}

void ContactServer::RequireNodeAtItsPoint(int k, const Eigen::Vector3d& x, const Eigen::Vector3d& v) const {
  // A free start: the node must start where its tied point is and as it moves (to round-off of
  // the scenario's numbers), or its tie yanks it there in the first step and the difference swings
  // on the stiff tie, undamped by the midpoint rule, for the whole run (a pad drawn 3.6 cm off its
  // point rang at ±72 m/s with exit 0; one left at rest on a turning hub at ±0.8 m/s).
  const int node = nodes_[static_cast<size_t>(k)];
  const Eigen::Vector3d x0 = simulation_->positions().segment<3>(3 * node);
  const Eigen::Vector3d v0 = simulation_->velocities().segment<3>(3 * node);
  const double x_tolerance = 1e-6 + 1e-9 * x.norm(), v_tolerance = 1e-4 + 1e-4 * v.norm();
  if ((x0 - x).norm() <= x_tolerance && (v0 - v).norm() <= v_tolerance) return;
  // (Short: the coordinator echoes a peer's reason cut to 200 characters; 10 digits place a node
  // within the tolerance.)
  const auto vec = [](const Eigen::Vector3d& a) {
    Eigen::Vector3d shown = a;  // (round-off of a zero component shown as 0)
    for (int j = 0; j < 3; ++j) shown(j) = std::abs(a(j)) <= 1e-12 * a.norm() ? 0.0 : a(j);
    char text[96];
    std::snprintf(text, sizeof text, "[%.10g, %.10g, %.10g]", shown(0), shown(1), shown(2));
    return std::string(text);
  };
  const std::string& name = simulation_->model().nodes[static_cast<size_t>(node)].name;
  throw InputError("contact node '" + name + "' is not at its tied point at the start: give it position " + vec(x) +
                   " m, velocity " + vec(v) + " m/s (coupling.interface_nodes)");
}

void ContactServer::CheckRestartedNodes(const coupling::RestartedNodes& restarted, const char* where) const {
  const std::string peer = channel_->options().peer;
  const int count = restarted.node_size();
  if (restarted.position_size() != 3 * count || restarted.velocity_size() != 3 * count) {
    throw InputError("coupling: " + std::string(where) + " from '" + peer + "' lists " + std::to_string(count) +
                     " nodes with " + std::to_string(restarted.position_size()) + " position and " +
                     std::to_string(restarted.velocity_size()) + " velocity values; expected " +
                     std::to_string(3 * count) + " of each (3 per node listed)");
  }
  std::vector<bool> listed(nodes_.size(), false);
  for (int r = 0; r < count; ++r) {
    const int k = restarted.node(r);
    if (k < 0 || static_cast<size_t>(k) >= nodes_.size() || listed[static_cast<size_t>(k)]) {
      throw InputError("coupling: " + std::string(where) + ".node[" + std::to_string(r) + "] from '" + peer + "' is " +
                       std::to_string(k) + "; expected the index of an interface node of the Hello (0 to " +
                       std::to_string(static_cast<int>(nodes_.size()) - 1) + "), each listed once");
    }
    listed[static_cast<size_t>(k)] = true;
    for (int j = 3 * r; j < 3 * r + 3; ++j) {
      if (!std::isfinite(restarted.position(j)) || !std::isfinite(restarted.velocity(j))) {
        throw InputError("coupling: " + std::string(where) + " from '" + peer + "' moves node " + std::to_string(k) +
                         " to a non-finite state (position[" + std::to_string(j) +
                         "] = " + interface::FormatNumber(restarted.position(j)) + ", velocity[" + std::to_string(j) +
                         "] = " + interface::FormatNumber(restarted.velocity(j)) + "); expected finite numbers");
      }
    }
  }
}

void ContactServer::AcceptStep(const coupling::RestartedNodes* restarted) {
  simulation_->CheckAccepted(t_ + h_);  // (the caller reports a failure)
  // The coordinator's restart at an impact moved these nodes' points at the step's end: each
  // node's accepted state follows its point (proto/coupling.proto, RestartedNodes).
  for (int r = 0; restarted != nullptr && r < restarted->node_size(); ++r) {
    simulation_->StartNodeAt(nodes_[static_cast<size_t>(restarted->node(r))], Triple(restarted->position(), 3 * r),
                             Triple(restarted->velocity(), 3 * r));
  }
  last_accepted_ = step_;
  accepted_time_ = t_ + h_;
  ++accepted_;
  step_ = -1;
  if (on_accept) on_accept(accepted_time_);
}

ContactServer::Outcome ContactServer::Handle(const Envelope& e) {
  const std::string peer = channel_->options().peer;
  switch (e.body_case()) {
    case Envelope::kStepBegin: {
      if (step_ >= 0) {
        // Protocol 3: the next step's StepBegin accepts the step under way (its StepEnd folded
        // into it). Accepted here; begun by the next call, once the caller has recorded this one.
        if (e.step() != step_ + 1) {
          throw InputError("coupling: StepBegin of step " + std::to_string(e.step()) + " from '" + peer +
                           "' while step " + std::to_string(step_) + " is under way; expected step " +
                           std::to_string(step_ + 1) + " (which accepts it) or a message of step " +
                           std::to_string(step_));
        }
        if (e.step_begin().has_restarted_nodes()) {
          CheckRestartedNodes(e.step_begin().restarted_nodes(), "StepBegin.restarted_nodes");
        }
        try {
          AcceptStep(e.step_begin().has_restarted_nodes() ? &e.step_begin().restarted_nodes() : nullptr);
        } catch (const Error& failure) {
          StopOnFailure(failure, e.step(), e.iteration());
          throw;
        }
        deferred_ = e;
        has_deferred_ = true;
        return Outcome::kAccepted;
      }
      if (e.step() != last_accepted_ + 1) {
        throw InputError("coupling: StepBegin of step " + std::to_string(e.step()) + " from '" + peer +
                         "', expected step " + std::to_string(last_accepted_ + 1));
      }
      if (e.step_begin().has_restarted_nodes() && !replaying_deferred_) {
        throw InputError("coupling: StepBegin of step " + std::to_string(e.step()) + " from '" + peer +
                         "' carries restarted_nodes but accepts no step (none was under way); expected them "
                         "only with the StepBegin that accepts the step of the restart");
      }
      if (!(e.step_begin().step() > 0.0) || !std::isfinite(e.step_begin().step())) {
        throw InputError("coupling: StepBegin.step from '" + peer + "' is " +
                         interface::FormatNumber(e.step_begin().step()) + "; expected a positive, finite step [s]");
      }
      if (!std::isfinite(e.step_begin().time())) {
        throw InputError("coupling: StepBegin.time from '" + peer + "' is " +
                         interface::FormatNumber(e.step_begin().time()) + "; expected a finite time [s]");
      }
      step_ = e.step();
      t_ = e.step_begin().time();
      h_ = e.step_begin().step();
      // The last accepted end is this step's start.
      for (size_t i = 0; i < moving_.size(); ++i) Frame(i).BeginStep(t_, h_);
      simulation_->SaveStart();  // the nodes' state: a rejected step comes back here
      if (e.step_begin().has_predictor()) SetReactions(e.step_begin().predictor(), "StepBegin.predictor");
      TentativeStep(step_, 0);  // the predictor, or the last accepted reactions
      return Outcome::kContinue;
    }
    case Envelope::kReactions: {
      if (e.step() != step_ || step_ < 0) {
        throw InputError("coupling: Reactions of step " + std::to_string(e.step()) + " from '" + peer +
                         "', but the step under way is " + std::to_string(step_));
      }
      SetReactions(e.reactions(), "Reactions");
      TentativeStep(step_, e.iteration());
      return Outcome::kContinue;
    }
    case Envelope::kStepEnd: {
      if (e.step() != step_ || step_ < 0) {
        throw InputError("coupling: StepEnd of step " + std::to_string(e.step()) + " from '" + peer +
                         "', but the step under way is " + std::to_string(step_));
      }
      const bool accepted = e.step_end().accepted();
      if (accepted) {
        try {
          AcceptStep();
        } catch (const Error& failure) {
          StopOnFailure(failure, e.step(), e.iteration());
          throw;
        }
      } else {
        simulation_->RestoreStart();  // the nodes' state at the step's start
        for (size_t i = 0; i < moving_.size(); ++i) Frame(i).RejectStep();
        ++rejected_;
        step_ = -1;
      }
      channel_->Outgoing(e.step(), e.iteration()).mutable_step_end()->set_accepted(accepted);
      channel_->Send();
      return accepted ? Outcome::kAccepted : Outcome::kContinue;
    }
    case Envelope::kShutdown: {
      if (step_ >= 0 && e.shutdown().has_last_accepted_step() && e.shutdown().last_accepted_step() >= step_) {
        // The coordinator accepted the step under way and ended the run before another began:
        // accepted here, the Shutdown answered by the next call (after the caller's record).
        if (e.shutdown().has_restarted_nodes()) {
          CheckRestartedNodes(e.shutdown().restarted_nodes(), "Shutdown.restarted_nodes");
        }
        AcceptStep(e.shutdown().has_restarted_nodes() ? &e.shutdown().restarted_nodes() : nullptr);
        deferred_ = e;
        has_deferred_ = true;
        return Outcome::kAccepted;
      }
      coordinator_exit_code_ = e.shutdown().exit_code();
      coordinator_reason_ = interface::EchoedText(e.shutdown().reason());
      channel_->Outgoing(-1, 0).mutable_shutdown()->set_exit_code(0);
      channel_->Send();
      return Outcome::kShutdown;
    }
    default:
      throw InputError("coupling: unexpected " + interface::BodyName(e.body_case()) + " from '" + peer +
                       "' (a contact process answers StepBegin, Reactions, StepEnd and Shutdown)");
  }
}

}  // namespace cosim::nonsmooth
