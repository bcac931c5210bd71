#include "smooth_solver/coupling/peer_link.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "interface/base/errors.h"
#include "interface/scenario/checks.h"
#include "smooth_solver/constraints/bilinear_constraints.h"

namespace cosim::smooth {

using coupling::Envelope;

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

PeerLink::PeerLink(const MultibodySystem& system, std::vector<Peer> peers)
    : system_(system), peers_(std::move(peers)), sent_frames_(peers_.size()) {}

bool PeerLink::Handshake(const Hello& start, const DaeState& frames) {
  for (Peer& peer : peers_) {
    auto* hello = peer.channel->Outgoing(-1, 0).mutable_hello();
    hello->set_scenario_name(start.scenario_name);
    hello->set_process_name(peer.channel->options().peer);
    for (int p : peer.points) hello->add_interface_nodes(system_.interface_points[static_cast<size_t>(p)].contact_node);
    hello->set_start_time(start.start_time);
    hello->set_step(start.step);
    if (start.node_positions != nullptr) {
      hello->set_settled(start.settled);
      for (int p : peer.points) {
        for (int j = 0; j < 3; ++j) {
          hello->add_node_positions((*start.node_positions)(3 * p + j));
          hello->add_node_velocities((*start.node_velocities)(3 * p + j));
        }
      }
    }
    for (const MovingObstacle& o : peer.obstacles) {
      hello->add_moving_obstacles(o.name);
      FillFrame(o.body, frames, 0.0, hello->add_obstacle_frames());
    }
    peer.channel->Send();
  }
  bool jacobians = true;
  for (Peer& peer : peers_) {
    const auto& welcome = peer.channel->Receive(Envelope::kWelcome, -1, -1).welcome();
    CheckWelcome(peer, welcome);
    peer.jacobians = welcome.interface_jacobians();
    jacobians = jacobians && peer.jacobians;
  }
  return jacobians;
}

void PeerLink::CheckWelcome(const Peer& peer, const coupling::Welcome& welcome) const {
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
}

void PeerLink::BeginStep(long long step, double t, double h, const ReactionsToSend& sent, const DaeState& frames,
                         double ahead, const MovedNodes& moved) {
  for (size_t q = 0; q < peers_.size(); ++q) {
    Peer& peer = peers_[q];
    auto* begin = peer.channel->Outgoing(step, 0).mutable_step_begin();  // (accepts a pending step)
    begin->set_time(t);
    begin->set_step(h);
    if (!moved.points.empty()) FillMovedNodes(peer, moved, begin->mutable_restarted_nodes());
    FillReactions(q, step, sent, frames, ahead, begin->mutable_predictor());
    peer.channel->Send();
  }
}

void PeerLink::Exchange(long long step, int iteration, const ReactionsToSend& sent, const DaeState& frames) {
  for (size_t q = 0; q < peers_.size(); ++q) {
    Peer& peer = peers_[q];
    FillReactions(q, step, sent, frames, 0.0, peer.channel->Outgoing(step, iteration).mutable_reactions());
    peer.channel->Send();
  }
}

void PeerLink::FillReactions(size_t q, long long step, const ReactionsToSend& sent, const DaeState& frames,
                             double ahead, coupling::Reactions* reactions) {
  const Peer& peer = peers_[q];
  sent_frames_[q].clear();
  for (const MovingObstacle& o : peer.obstacles) {
    sent_frames_[q].push_back(FillFrame(o.body, frames, ahead, reactions->add_obstacle_frames()));
  }
  for (int p : peer.points) {
    // This side's own numbers: a non-finite one is its numerical failure (exit 3), not a
    // message for the peer to refuse as bad input.
    const Eigen::Vector3d force = sent.force.segment<3>(3 * p);
    if (!force.allFinite() || (sent.jacobians && !(sent.stiffness[static_cast<size_t>(p)].allFinite() &&
                                                   sent.position.segment<3>(3 * p).allFinite()))) {
      throw NumericalError("coupling: the reaction of interface node '" +
                           system_.interface_points[static_cast<size_t>(p)].contact_node + "' is not finite (force [" +
                           interface::FormatNumber(force(0)) + ", " + interface::FormatNumber(force(1)) + ", " +
                           interface::FormatNumber(force(2)) + "] N) in step " + std::to_string(step) +
                           ": the smooth step has failed");
    }
    for (int j = 0; j < 3; ++j) reactions->add_force(force(j));
    if (!sent.jacobians) continue;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) reactions->add_stiffness(sent.stiffness[static_cast<size_t>(p)](r, c));
    }
    for (int j = 0; j < 3; ++j) reactions->add_position(sent.position(3 * p + j));
  }
}

void PeerLink::Receive(long long step, int iteration, bool jacobians, const Eigen::VectorXd& sent,
                       PeerAnswers* answers) {
  answers->in_contact = false;
  std::fill(answers->contact.begin(), answers->contact.end(), false);
  answers->time_to_contact = std::numeric_limits<double>::infinity();
  for (Peer& peer : peers_) {
    const std::string& name = peer.channel->options().peer;
    const auto& k = peer.channel->Receive(Envelope::kKinematics, step, iteration).kinematics();
    const int expected = 3 * static_cast<int>(peer.points.size());
    if (k.position_size() != expected || k.velocity_size() != expected) {
      throw InputError("coupling: Kinematics from '" + name + "' has " + std::to_string(k.position_size()) +
                       " positions and " + std::to_string(k.velocity_size()) + " velocities; expected " +
                       std::to_string(expected) + " of each");
    }
    for (int i = 0; i < expected; ++i) {
      if (!std::isfinite(k.position(i)) || !std::isfinite(k.velocity(i))) {
        throw InputError("coupling: Kinematics from '" + name + "' of step " + std::to_string(step) +
                         " has a non-finite value at index " + std::to_string(i) + " (position " +
                         interface::FormatNumber(k.position(i)) + ", velocity " +
                         interface::FormatNumber(k.velocity(i)) + "); expected finite numbers");
      }
    }
    if (k.in_contact_size() != 0 && k.in_contact_size() != static_cast<int>(peer.points.size())) {
      throw InputError("coupling: Kinematics.in_contact from '" + name + "' has " +
                       std::to_string(k.in_contact_size()) + " values; expected one per interface node (" +
                       std::to_string(peer.points.size()) + ") or none");
    }
    for (int i = 0; i < k.in_contact_size(); ++i) {
      answers->contact[static_cast<size_t>(peer.points[static_cast<size_t>(i)])] = k.in_contact(i) != 0;
      answers->in_contact = answers->in_contact || k.in_contact(i) != 0;
    }
    // An older peer that does not say: a contact is always possible.
    const double ttc = k.has_time_to_contact() ? k.time_to_contact() : 0.0;
    if (std::isnan(ttc) || ttc < 0.0) {
      throw InputError("coupling: Kinematics.time_to_contact from '" + name + "' of step " + std::to_string(step) +
                       " is " + interface::FormatNumber(ttc) + "; expected a time >= 0 [s] (or +inf)");
    }
    answers->time_to_contact = std::min(answers->time_to_contact, ttc);
    for (size_t i = 0; i < peer.points.size(); ++i) {
      for (int j = 0; j < 3; ++j) {
        const Eigen::Index v = 3 * peer.points[i] + j;
        answers->position(v) = k.position(3 * static_cast<int>(i) + j);
        answers->velocity(v) = k.velocity(3 * static_cast<int>(i) + j);
        answers->applied(v) = sent(v);  // (a peer that does not say held the force it was sent)
      }
    }
    if (!jacobians) continue;
    // The force it held and its sensitivities (protocol 3): 3 and 9 per node, finite.
    auto check = [&](const char* field, int size, int want, bool optional,
                     const google::protobuf::RepeatedField<double>& values) {
      if (size == 0 && optional) return false;
      if (size != want) {
        throw InputError("coupling: Kinematics." + std::string(field) + " from '" + name + "' of step " +
                         std::to_string(step) + " has " + std::to_string(size) + " values; expected " +
                         std::to_string(want) + (optional ? " or none" : " (its Welcome offered interface Jacobians)"));
      }
      for (int i = 0; i < size; ++i) {
        if (!std::isfinite(values.Get(i))) {
          throw InputError("coupling: Kinematics." + std::string(field) + "[" + std::to_string(i) + "] from '" + name +
                           "' of step " + std::to_string(step) + " is " + interface::FormatNumber(values.Get(i)) +
                           "; expected a finite number");
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
        for (int j = 0; j < 3; ++j) answers->applied(3 * p + j) = k.applied_force(3 * i + j);
      }
      answers->sensitivity[static_cast<size_t>(p)] = Block(k.position_sensitivity().data() + 9 * i);
    }
  }
}

void PeerLink::EndStep(long long step, int iteration, bool accepted, bool converged) {
  for (Peer& peer : peers_) {
    auto* end = peer.channel->Outgoing(step, iteration).mutable_step_end();
    end->set_accepted(accepted);
    end->set_converged(converged);
    peer.channel->Send();
  }
  for (Peer& peer : peers_) peer.channel->Receive(Envelope::kStepEnd, step, iteration);
}

void PeerLink::Shutdown(int exit_code, const std::string& reason, long long last_accepted, const MovedNodes& moved,
                        bool wait_for_replies) {
  for (Peer& peer : peers_) {
    if (peer.channel->peer_stopped()) continue;  // it said Shutdown itself: it is gone
    auto* stop = peer.channel->Outgoing(-1, 0).mutable_shutdown();
    stop->set_exit_code(exit_code);
    stop->set_reason(reason);
    stop->set_last_accepted_step(last_accepted);
    if (!moved.points.empty()) FillMovedNodes(peer, moved, stop->mutable_restarted_nodes());
    peer.channel->Send();
  }
  if (!wait_for_replies) return;
  for (Peer& peer : peers_) {
    if (!peer.channel->peer_stopped()) peer.channel->Receive(Envelope::kShutdown, -1, -1);
  }
}

void PeerLink::FillMovedNodes(const Peer& peer, const MovedNodes& moved, coupling::RestartedNodes* out) const {
  for (size_t i = 0; i < peer.points.size(); ++i) {
    const int k = peer.points[i];
    if (std::find(moved.points.begin(), moved.points.end(), k) == moved.points.end()) continue;
    out->add_node(static_cast<int>(i));
    for (int j = 0; j < 3; ++j) out->add_position(moved.position(3 * k + j));
    for (int j = 0; j < 3; ++j) out->add_velocity(moved.velocity(3 * k + j));
  }
}

double PeerLink::FrameDrift(const DaeState& state, const PeerAnswers& answers) const {
  double drift = 0.0;
  for (size_t q = 0; q < peers_.size(); ++q) {
    for (size_t i = 0; i < peers_[q].obstacles.size(); ++i) {
      coupling::Frame frame;
      const auto [c, R] = FillFrame(peers_[q].obstacles[i].body, state, 0.0, &frame);
      const auto& [c0, R0] = sent_frames_[q][i];
      for (int p : peers_[q].points) {
        if (!answers.contact[static_cast<size_t>(p)]) continue;  // (a node off its planes does not feel them move)
        const Eigen::Vector3d k = answers.position.segment<3>(3 * p);
        drift = std::max(
            drift,
            ((c - c0) + (R * R0.transpose() - Eigen::Matrix3d::Identity()) * (k - c0)).lpNorm<Eigen::Infinity>());
      }
    }
  }
  return drift;
}

}  // namespace cosim::smooth
