#pragma once
// The contact process's side of the coupling protocol (proto/coupling.proto): it answers the
// coordinator (smooth_solver) message by message, each coupling iteration one tentative
// step of its ContactStepper (Moreau–Jean or penalty) from the step's start with the reactions it was sent as external
// forces on the interface nodes [rotor-sailing paper, Section 2]:
//
//   Hello      → Welcome      the interface nodes are looked up (unknown: InputError, exit 2)
//   StepBegin  → Kinematics 0 a checkpoint of the step's start, and a tentative step with the
//                             coordinator's predicted reactions (or the last accepted ones)
//   Reactions i → Kinematics i reactions and frames set (the step's inputs), back to the
//                             checkpoint (the state), one step
//   StepEnd    → StepEnd      accepted: keep the last tentative step; rejected: back to the
//                             checkpoint, the frames' ends to their starts
//   StepBegin of the next step, while a step waits for its StepEnd: accepts it (protocol 3:
//                             the coordinator folds the StepEnd of an accepted step into the
//                             next StepBegin); the StepBegin is then served by the next
//                             ServeStep, after the caller has recorded the accepted step
//   Shutdown   → Shutdown     end of the run (accepting a waiting step up to its
//                             last_accepted_step)
// With interface Jacobians (ContactStepper::SupportsInterfaceJacobians, Welcome.interface_jacobians)
// each step takes Reactions.stiffness as an implicit force law and Kinematics carries the held
// force and the nodes' sensitivities (docs/protocol.md).
//
// A step that fails (NumericalError) is reported to the coordinator with Shutdown(exit 3) before
// the error goes on up. Accepted steps are counted; `on_accept` (if set) is called after each,
// for the run's history rows.
#include <functional>
#include <string>
#include <vector>

#include "interface/coupling/channel.h"
#include "nonsmooth_solver/coupling/contact_stepper.h"

namespace cosim::nonsmooth {

class ContactServer {
 public:
  ContactServer(ContactStepper* simulation, interface::Channel* channel, std::string scenario_name);

  // Serves until the coordinator's Shutdown. Throws PeerError (the coordinator vanished or
  // stopped), InputError (a refused message) or NumericalError (a failed step).
  void Run();

  // The same, step by step (a contact process inside the run driver's time loop):
  void Handshake();                                  // Hello → Welcome
  void ServeStep(int64_t step, double t, double h);  // until step `step` (t, h) is accepted
  // Adaptive steps (numerics.adaptive): the coordinator chooses each step and may reject it;
  // serves until an accepted step ends at `time` or later (each StepBegin must start where the
  // last accepted step ended). Returns at once if one already has.
  void ServeUntil(double time);
  double accepted_time() const { return accepted_time_; }  // end of the last accepted step
  void ServeShutdown();                                    // the coordinator's Shutdown → reply

  std::function<void(double time)> on_accept;
  // numerics.adaptive.resting_speed [m/s] (Kinematics.time_to_contact; ContactStepper::TimeToContact).
  void set_resting_speed(double speed) { resting_speed_ = speed; }
  // A restarted process (ContactStepper::UseSavedState): its attached obstacles keep the saved
  // body-frame geometry, which the Hello's frames (the body as it has turned since) must not redo.
  void keep_attached_geometry() { keep_attached_geometry_ = true; }
  long long accepted_steps() const { return accepted_; }
  long long tentative_steps() const { return tentative_; }
  long long rejected_steps() const { return rejected_; }              // StepEnd(accepted = false): adaptive steps
  const std::vector<int>& interface_nodes() const { return nodes_; }  // model node indices

 private:
  void Answer(const coupling::Envelope& hello);
  enum class Outcome { kContinue, kAccepted, kShutdown };
  Outcome Handle(const coupling::Envelope& e);  // one message, answered
  const coupling::Envelope& Next();             // a deferred message first, else the channel's next
  // The step under way is accepted; `restarted` (the accepting message's, or null): the nodes
  // the coordinator's restart at an impact moved, checked by CheckRestartedNodes.
  void AcceptStep(const coupling::RestartedNodes* restarted = nullptr);
  void CheckRestartedNodes(const coupling::RestartedNodes& restarted, const char* where) const;
  // A free start's Hello: node k (in the Hello's order) at its tied point's position x and velocity
  // v to round-off, else refused (InputError naming the node and both states).
  void RequireNodeAtItsPoint(int k, const Eigen::Vector3d& x, const Eigen::Vector3d& v) const;
  void TentativeStep(int64_t step, int iteration);
  void StopOnFailure(const Error& e, int64_t step, int iteration);  // Shutdown with its code and reason
  // The coordinator's Shutdown came before `before` (a step, a time): ends this process with it.
  [[noreturn]] void ThrowStopped(const std::string& before) const;
  // Checked, into external_ and the moving obstacles' end frames.
  void SetReactions(const coupling::Reactions& reactions, const char* where);
  BodyFrame ReadFrame(const coupling::Frame& frame, const std::string& where) const;  // checked
  std::vector<int> moving_;  // ContactData::frames index of each Hello.moving_obstacles entry
  DrivenFrame& Frame(size_t i) { return simulation_->mutable_data()->frames[static_cast<size_t>(moving_[i])]; }
  int coordinator_exit_code_ = 0;
  std::string coordinator_reason_;

  ContactStepper* simulation_;
  interface::Channel* channel_;
  std::string scenario_name_;
  std::vector<int> nodes_;
  Eigen::VectorXd external_;  // 3 per model node: the interface nodes' reactions, 0 elsewhere
  // Reactions.stiffness and .position in model order (9 and 3 per model node, 0 elsewhere);
  // empty when the last Reactions had none.
  Eigen::VectorXd stiffness_, reference_;
  bool jacobians_ = false;  // the stepper supports them (and was told so)
  // A message that ended a step (a StepBegin accepting the one under way, a Shutdown) and is
  // served by the next call.
  coupling::Envelope deferred_;
  bool has_deferred_ = false;
  bool replaying_deferred_ = false;                              // Handle's message is deferred_ (its acceptance done)
  Eigen::VectorXd sensitivity_position_, sensitivity_velocity_;  // scratch
  double t_ = 0.0, h_ = 0.0;
  int64_t step_ = -1;  // the step under way
  int64_t last_accepted_ = -1;
  double accepted_time_ = 0.0;
  bool keep_attached_geometry_ = false;
  double resting_speed_ = 0.0;
  long long rejected_ = 0;
  long long accepted_ = 0, tentative_ = 0;
};

}  // namespace cosim::nonsmooth
