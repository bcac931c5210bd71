#pragma once
// The coordinator's side of the coupling protocol (docs/protocol.md), the twin of the contact
// processes' ContactServer: its peers (one channel each, the interface points whose nodes it
// steps, the obstacles it moves with bodies of the smooth model), the handshake, and each
// message of a step sent to every peer and its answer received from every peer and checked.
// What the messages carry (the reactions, the peers' answers) is the coordinator's; how it is
// written into and read out of the messages is this link's.
#include <string>
#include <utility>
#include <vector>

#include "interface/coupling/channel.h"
#include "smooth_solver/integrator/smooth_integrator.h"
#include "smooth_solver/model/multibody_system.h"

namespace cosim::smooth {

// What the peers answered in their last Kinematics, per interface value (3 per interface point,
// in MultibodySystem::interface_points order).
struct PeerAnswers {
  Eigen::VectorXd position, velocity;  // k: the nodes' end-of-step positions [m] and velocities [m/s]
  // x̃: the force each node held [N] (interface Jacobians); a peer that does not say held the
  // force it was sent.
  Eigen::VectorXd applied;
  std::vector<Eigen::Matrix3d> sensitivity;  // S = ∂k/∂x per point (interface Jacobians) [m/N]
  std::vector<bool> contact;                 // per point: its node in contact at the step's end
  bool in_contact = false;                   // any node
  double time_to_contact = 0.0;              // the peers' earliest, from the step's end [s]
};

// What goes with a StepBegin's predictor or a Reactions, per interface value: the force x, and
// with interface Jacobians the smooth side's stiffness E = ∂x/∂k per point and the positions k̂
// at which it was linearised.
struct ReactionsToSend {
  const Eigen::VectorXd& force;
  bool jacobians;
  const std::vector<Eigen::Matrix3d>& stiffness;
  const Eigen::VectorXd& position;
};

// The interface points whose nodes an impact's restart moved, with the accepted kinematics the
// nodes take (RestartedNodes in proto/coupling.proto).
struct MovedNodes {
  const std::vector<int>& points;
  const Eigen::VectorXd& position;
  const Eigen::VectorXd& velocity;
};

class PeerLink {
 public:
  // An obstacle of a contact process attached to a rigid body of the smooth model: the body's
  // frame goes with Hello (start), StepBegin (predicted) and every Reactions (iterate).
  struct MovingObstacle {
    std::string name;
    int body = 0;
  };
  struct Peer {
    interface::Channel* channel;
    std::vector<int> points;  // indices into MultibodySystem::interface_points, in Hello order
    std::vector<MovingObstacle> obstacles = {};
    bool jacobians = false;  // its Welcome offered interface Jacobians
  };
  // The Hello's contents beyond the peers' own nodes and obstacles.
  struct Hello {
    std::string scenario_name;
    double start_time = 0.0;
    double step = 0.0;
    // A fresh start: the nodes' start positions and velocities per interface value, which each
    // peer checks against its nodes' scenario state, and whether they are a settled start's. A
    // run continued from a saved state sends none (both are null).
    const Eigen::VectorXd* node_positions = nullptr;
    const Eigen::VectorXd* node_velocities = nullptr;
    bool settled = false;
  };

  PeerLink(const MultibodySystem& system, std::vector<Peer> peers);

  // Hello → Welcome with every peer (the obstacles' frames from `frames`), each Welcome checked
  // against its Hello (InputError). Whether every peer offered interface Jacobians.
  [[nodiscard]] bool Handshake(const Hello& hello, const DaeState& frames);
  // StepBegin of step `step` (t, h) to every peer: its predictor `sent`, the moving obstacles'
  // frames of `frames` advanced by `ahead` [s] at their rates, and the nodes `moved` by the
  // accepted step's restart (the StepBegin accepts that step at the peers).
  void BeginStep(long long step, double t, double h, const ReactionsToSend& sent, const DaeState& frames, double ahead,
                 const MovedNodes& moved);
  // Reactions of `iteration` (`sent`, the frames of `frames`) to every peer.
  void Exchange(long long step, int iteration, const ReactionsToSend& sent, const DaeState& frames);
  // Every peer's Kinematics of `iteration`, checked (InputError), into `answers`; `sent`: the
  // force each peer was sent (what it held if it does not say); `jacobians`: the step iterates
  // with interface Jacobians, whose answers carry sensitivities.
  void Receive(long long step, int iteration, bool jacobians, const Eigen::VectorXd& sent, PeerAnswers* answers);
  // StepEnd to every peer (a rejected or accepted step of the adaptive driver), and their replies.
  void EndStep(long long step, int iteration, bool accepted, bool converged);
  // Shutdown to every peer still there (exit code 0, or the failure's code and reason), with the
  // last accepted step and the nodes `moved` by its restart; with `wait_for_replies`, each one's
  // Shutdown.
  void Shutdown(int exit_code, const std::string& reason, long long last_accepted, const MovedNodes& moved,
                bool wait_for_replies);
  // How far the moving obstacles' frames at `state` are from those the peers stepped with, at
  // their nodes in contact in `answers` [m].
  [[nodiscard]] double FrameDrift(const DaeState& state, const PeerAnswers& answers) const;

 private:
  // Peer q's reactions and its obstacles' frames of `frames` advanced `ahead` (recorded in
  // sent_frames_): the body of a StepBegin's predictor or of a Reactions.
  void FillReactions(size_t q, long long step, const ReactionsToSend& sent, const DaeState& frames, double ahead,
                     coupling::Reactions* reactions);
  void FillMovedNodes(const Peer& peer, const MovedNodes& moved, coupling::RestartedNodes* out) const;
  void CheckWelcome(const Peer& peer, const coupling::Welcome& welcome) const;

  const MultibodySystem& system_;
  std::vector<Peer> peers_;
  // The moving obstacles' frames the peers stepped with (origin, rotation), peer by peer.
  std::vector<std::vector<std::pair<Eigen::Vector3d, Eigen::Matrix3d>>> sent_frames_;
};

}  // namespace cosim::smooth
