#pragma once
// The coordinator of a coupled step (rotor-sailing paper, Section 2): the contact processes and
// the smooth model iterate inside every time step until both agree. It owns the step: the
// checkpoint at its start, the smooth solves, the messages to and from the peers (PeerLink), the
// accepted steps' memory (CouplingMemory) and what happens at an impact; the coupling method
// (CouplingMethod: interface Jacobians, or a relaxation) decides what each solve imposes, whether
// the two sides agree and what is sent next:
//
//   StepBegin → every peer: predicted reactions x_0 (extrapolated from the accepted steps), the
//               obstacle frames (the bodies' frames advanced by their velocities) and, with
//               interface Jacobians, the linearisation of a pre-solve → k_0
//   for i = 0, 1, ...:
//     impose k_i (the method's); CGα step from the step's start → multipliers → x̃_i
//     converged (the method's test): accept the step
//     else x_{i+1} (the method's) → every peer: Reactions(i+1) → Kinematics k_{i+1}
//   at the iteration limit: STOP (NumericalError, exit 3) or ACCEPT_AND_MARK (logged).
// After a step in which a node's contact closed (an impact: its velocity jumped), the smooth
// integrator restarts its acceleration history from the accelerations with the coupling rows
// left out: CGα's a-recursion assumes smooth motion and, carried across the jump, turns the
// next steps' multipliers into spikes that throw the pair off (observed: a bouncing pair
// rebounding 3× too high).
//
// x are the forces the smooth model exerts on the interface nodes (the coincidence rows'
// multipliers), k the nodes' end-of-step positions and velocities. The imposed acceleration
// is the velocity change over the step divided by h.
#include <string>
#include <vector>

#include "smooth_solver/coupling/coupling_memory.h"
#include "smooth_solver/coupling/coupling_method.h"
#include "smooth_solver/coupling/interface_jacobian_method.h"
#include "smooth_solver/coupling/peer_link.h"
#include "smooth_solver/coupling/relaxation_method.h"
#include "smooth_solver/integrator/cgalpha.h"
#include "state.pb.h"

namespace cosim::smooth {

class Coordinator {
 public:
  using MovingObstacle = PeerLink::MovingObstacle;
  using Peer = PeerLink::Peer;
  // `data`: the run's changing state (the one `integrator` was made with), where the interface
  // rows' imposed coordinates are written; the integrator's checkpoints hold it.
  Coordinator(const MultibodySystem& system, SystemData* data, CgAlpha* integrator, std::vector<Peer> peers,
              const CouplingSettings& settings);

  // Hello → Welcome with every peer. A fresh start (or a restart whose CGα history starts
  // afresh) starts the coupling with the interface rows free; after ReadMemory the run goes on
  // with them held, from the restored multipliers and memory.
  void Handshake(const std::string& scenario_name, double start_time, double step);
  // What the next step starts from (state.proto's CoordinatorMemory), for a restart.
  void WriteMemory(state::CoordinatorMemory* out) const;
  // Reads a WriteMemory of this scene's coupling (before the handshake; the integrator and
  // the data restored with it). The reason a memory is refused (another number of points, sizes
  // that do not match, non-finite values: the run ends with it); empty if none.
  [[nodiscard]] std::string ReadMemory(const state::CoordinatorMemory& in);
  // One coupled step from t to t + h (fixed steps): Try, then Accept. A failed Newton solve or
  // (with stop_at_max_iterations) no convergence rejects the step and retries it as two halves,
  // then quarters (StepOrSplit); if a quarter fails too, NumericalError. Returns the coupling
  // iterations used.
  int Step(double t, double h);

  // The adaptive step's pieces. Try: the coupling iterations of the step from t to t + h,
  // committed to nothing: the integrator holds the last iteration's end state, every peer its
  // tentative step. Then exactly one of Accept (StepEnd accepted) or Reject (StepEnd rejected:
  // every peer and the integrator back at the step's start; the next Try may take another h).
  // What a Try came to, and its statistics; Describe turns a failure into words (the run driver's).
  struct Attempt {
    enum class Outcome : unsigned char {
      kConverged,           // within the tolerances (or free flight)
      kNotConverged,        // max_iterations reached
      kSmoothFailed,        // a CGα solve failed (integrator restored): `smooth` says how
      kReactionsNotFinite,  // the smooth model's reactions on the nodes are not finite
    };
    Outcome outcome = Outcome::kConverged;
    int iterations = 0;
    double end_time = 0.0;         // the step's end t + h [s]
    bool free_flight = false;      // accepted after one iteration: no contact reachable (free_flight_margin)
    bool impact = false;           // a node's contact closed in the step (its velocity jumped)
    bool contact = false;          // an impulsive contact acted in the step
    double time_to_contact = 0.0;  // the peers' earliest, from the step's end [s]
    int failed_iteration = -1;     // kSmoothFailed, kReactionsNotFinite: the coupling iteration
    bool with_answers = false;     // kSmoothFailed: the solve imposed the contact processes' answers
    StepStatus smooth;             // kSmoothFailed: CGα's status
    bool converged() const { return outcome == Outcome::kConverged; }
    bool failed() const { return outcome == Outcome::kSmoothFailed || outcome == Outcome::kReactionsNotFinite; }
  };
  [[nodiscard]] Attempt Try(double t, double h);
  void Accept(double t, double h);
  void Reject();
  // Why `attempt` (the last Try's, not converged) did not converge or failed, with the coupling
  // state it left (CouplingState): the message of its NumericalError or rejected step.
  std::string Describe(const Attempt& attempt) const;
  // The integrator's state at the start of the step under way (or of the last one tried): what a
  // rejected step returns to.
  const CgAlpha::Checkpoint& start() const { return start_; }
  // The interface nodes in contact and the largest force mismatch, for a failed step's reason.
  std::string CouplingState() const;
  long long rejected_steps() const { return rejected_; }
  long long free_flight_steps() const { return free_flight_; }  // steps accepted after one iteration
  // Coupling iterations whose smooth solve failed and were redone with a halved update.
  long long backtracks() const { return backtracks_; }
  // Steps whose linearising pre-solve failed and that took the predictions as the point instead.
  long long linearisation_fallbacks() const { return method_->linearisation_fallbacks(); }
  // Steps whose impacts, left to their ties, had the impacting elastic bodies' acceleration
  // history replaced by the step before's (HoldImpactingBodiesHistory).
  long long impacts_held() const { return impacts_held_; }
  // Steps accepted on the linearising pre-solve: the peers' answer agreed with it (no second solve).
  long long linearisation_accepted() const { return method_->linearisation_accepted(); }
  // Whether the steps iterate with interface Jacobians (every peer offered them).
  bool interface_jacobians() const { return method_ == &jacobian_method_; }
  // Tells every peer the run is over (exit code 0, or the failure's code and reason) and, with
  // `wait_for_replies`, waits for each one's Shutdown.
  void Shutdown(int exit_code, const std::string& reason, bool wait_for_replies = true);

  // The iterations of the last step (or of the step under way when it failed).
  const std::vector<CouplingIterationRecord>& log() const { return log_; }
  int last_newton_iterations() const { return newton_; }  // CGα iterations of the last step, all tries
  long long marked_steps() const { return marked_; }
  long long retried_steps() const { return retried_; }  // fixed steps redone as halves (or quarters)
  // Steps accepted with the reaction residual at round-off but above the tolerance.
  long long roundoff_steps() const { return method_->roundoff_steps(); }

 private:
  // CGα from `state` at t, its accelerations with the coupling rows of `points` left out.
  void RestartWithCouplingRowsFree(DaeState state, double t, const std::vector<int>& points);
  // The interface points whose node's contact closed in this step (in contact, not in the last
  // accepted one): impacts.
  std::vector<int> Impacts() const;
  // After an accepted step with impacts at elastic nodes (`impacts` not in `restarted`): their
  // bodies' a_{n+1} and q̈_{n+1} become the step before's (the impulse kept out of CGα's recurrence).
  void HoldImpactingBodiesHistory(const std::vector<int>& impacts, const std::vector<int>& restarted, double t,
                                  double h);
  std::vector<int> BodiesTheImpulseMovedInTheStep(int k, double t, double h) const;
  // After an accepted step with impacts: the restart at them (restart_at_impact), or the history
  // held (HoldImpactingBodiesHistory).
  void AfterImpacts(const std::vector<int>& impacts, double t, double h);
  // A restart at an impact moved the rigid bodies' velocities from `before` (the step's end) to
  // `after` (projected): the nodes of the other points on them take their points' jumps
  // (RestartedNodes in proto/coupling.proto); the imposed rates and the kinematics are updated
  // here, the peers told with the next StepBegin or the Shutdown (MovedNodes).
  void MoveNodesWithRestart(const DaeState& before, const DaeState& after, const std::vector<int>& restarted);
  // After an impact's restart: the bodies whose positions and velocities it did not change take
  // back their acceleration history (`before`, `a_before`: the step's state before the restart).
  void KeepHistoryTheRestartDidNotChange(const DaeState& before, const Eigen::VectorXd& a_before);

  // The stages of a step (Try).
  // The step's start saved, and the reactions predicted.
  void BeginTry(double h);
  // With interface Jacobians: the pre-solve of a step (the smooth side alone, its interface
  // points following the peers' last affine answers from predicted positions) that gives the
  // linearisation point x̂, k̂ sent with StepBegin; if it fails, the predictions are the point.
  void PreSolve(double t, double h);
  // StepBegin (x and the method's linearisation) to every peer, the moving obstacles' frames of
  // `frames` advanced by `ahead` [s], and the peers' kinematics.
  void BeginStep(double t, double h, const DaeState& frames, double ahead);
  // Reactions of `iteration` (x, the frames of `frames`) to every peer, and their kinematics.
  void Exchange(int iteration, const DaeState& frames);
  ReactionsToSend Sent() const;
  MovedNodes Moved() const { return {moved_points_, memory_.accepted_position, memory_.accepted_velocity}; }
  // One CGα solve of the step (from `guess`, or the predictor): iterate_ and x̃ from it; its
  // status (a failed one leaves the integrator at the step's start).
  StepStatus SolveStep(double t, double h, const DaeState* guess);
  Attempt Failed(int at, Attempt::Outcome outcome, Attempt result);
  Attempt Finished(int last, Attempt result);
  int StepOrSplit(double t, double h, int depth);

  const MultibodySystem& system_;
  SystemData* data_;
  CgAlpha* integrator_;
  CouplingSettings settings_;
  PeerLink link_;
  int n_ = 0;              // interface values: 3 per point
  CouplingIterate it_;     // the step under way's x, x̃ and the peers' answers
  CouplingMemory memory_;  // what the next step starts from (saved with a state)
  InterfaceRows rows_;
  StepReaction reaction_;
  InterfaceJacobianMethod jacobian_method_;
  RelaxationMethod relaxation_method_;
  CouplingMethod* method_ = &relaxation_method_;  // the handshake's choice
  CgAlpha::Checkpoint start_;
  DaeState iterate_;  // the end state of the step's last solved coupling iteration (Newton's start for the next)
  bool iterate_solved_ = false;                  // iterate_ is a solve of the step under way
  Eigen::VectorXd held_a_, held_qddot_;          // HoldImpactingBodiesHistory's buffers
  std::vector<int> moved_points_;                // MoveNodesWithRestart's, until the peers are told
  std::vector<Eigen::Vector3d> impact_normals_;  // Accept's impact reactions' directions, one per point
  bool restored_ = false;                        // ReadMemory: the handshake goes on with the rows held
  bool resting_at_start_ = false;                // a settled start's first step: its contacts rest (Impacts)
  long long step_ = 0;
  long long last_accepted_ = -1;
  int last_iteration_ = 0;  // of the last Try
  // What the peers said at the last accepted step besides their law (in memory_): Reject puts it
  // back, so that a rejected step leaves no trace in the next try.
  bool accepted_in_contact_ = false;
  double accepted_time_to_contact_ = 0.0;
  std::vector<CouplingIterationRecord> log_;
  int newton_ = 0;
  long long rejected_ = 0, free_flight_ = 0, backtracks_ = 0, marked_ = 0, retried_ = 0, impacts_held_ = 0;
};

}  // namespace cosim::smooth
