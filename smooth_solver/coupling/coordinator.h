#pragma once
// The coordinator of a coupled step (rotor-sailing paper, Section 2): the contact processes and
// the smooth model iterate inside every time step until both agree.
//
// With interface Jacobians (the default when every peer offers them; docs/protocol.md): a
// pre-solve linearises the smooth side (x̂, k̂, E = ∂x/∂k per node), the peers step with that
// implicit force law and answer with the force they held and their sensitivities S, and the
// smooth step solves with k = k̃ + S (x − x̃) on its interface rows; the step is accepted when its
// force is the one the peers held (Linearise, BeginStep, SolveStep, JacobianConverged; a
// Newton iteration on the interface, one exchange a step while no contact set changes).
//
// Without (a relaxation):
//
//   StepBegin → every peer: predicted reactions x_0 (extrapolated from the accepted steps) and
//               obstacle frames (the bodies' frames advanced by their velocities) → k_0
//   for i = 0, 1, ...:
//     impose k_i on the interface points; CGα step from the step's start → multipliers → x̃_i
//     converged if |x̃_i − x_i| <= reaction_tolerance · max(1 N, |x̃_i|) and (i > 0)
//       |k_i − k_{i−1}| <= displacement_tolerance on the positions: accept the step; with the
//       kinematics unchanged to round-off, |x̃_i − x_i| <= |x̃_i − x̃_{i−1}| passes too (the
//       reaction's own round-off)
//     else x_{i+1} = relaxation(x_i, x̃_i) → every peer: Reactions(i+1) → Kinematics k_{i+1}
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

#include "interface/coupling/channel.h"
#include "interface/coupling/relaxation.h"
#include "smooth_solver/integrator/cgalpha.h"
#include "state.pb.h"

namespace cosim::smooth {

struct CouplingSettings {
  // The smooth model starts settled on the nodes (numerics.smooth.settle): the state's coupling
  // rows hold, their multipliers are the nodes' first reactions.
  bool settled_start = false;
  int max_iterations = 50;
  double displacement_tolerance = 1e-9;  // [m], absolute, on the interface positions
  double reaction_tolerance = 1e-6;      // relative to max(1 N, |x̃|)
  interface::Relaxation::Method relaxation = interface::Relaxation::Method::kAitken;
  double relaxation_factor = 0.5;
  int reuse_steps = 0;                 // IQN-ILS: columns of that many earlier steps kept
  bool step_average_reaction = false;  // false: λ at the step's end (see scenario.proto)
  bool stop_at_max_iterations = true;  // false: accept and mark the step
  bool restart_at_impact = true;       // see scenario.proto, CouplingIteration
  bool warm_start = true;              // Newton from the last coupling iteration's end (scenario.proto)
  // Interface Jacobians (docs/protocol.md) with every peer that offers them: the peers take the
  // smooth side's linearisation as an implicit force law and answer with their sensitivities,
  // which the smooth step takes as a compliance on the interface rows (a Newton iteration on
  // the interface). false: the relaxation above with every peer.
  bool interface_jacobians = true;
  // Interface Jacobians: a step whose peers' first answer agrees with the linearising pre-solve
  // is accepted on it, without a second smooth solve (scenario.proto,
  // CouplingIteration.accept_agreeing_linearisation).
  bool accept_agreeing_linearisation = true;
  // > 0: a step whose peers report no contact within this many steps of its end is accepted
  // after its first iteration if the reaction residual meets the tolerance (scenario.proto,
  // CouplingIteration.free_flight_margin); 0: always confirm with a second iteration.
  double free_flight_margin = 0.0;
};

// One iteration's record, for the convergence log.
struct CouplingIterationRecord {
  long long step = 0;
  int iteration = 0;
  double reaction_residual = 0.0;    // |x̃ − x|∞ [N]
  double displacement_change = 0.0;  // |k_i − k_{i−1}|∞ on positions [m] (∞ at i = 0)
  double relaxation_factor = 0.0;
};

class Coordinator {
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
  // `data`: the run's changing state (the one `integrator` was made with), where the interface
  // rows' imposed coordinates are written; the integrator's checkpoints hold it.
  Coordinator(const MultibodySystem& system, SystemData* data, CgAlpha* integrator, std::vector<Peer> peers,
              const CouplingSettings& settings);

  // Hello → Welcome with every peer. A fresh start (or a restart whose CGα history starts
  // afresh) starts the coupling with the interface rows free; after RestoreMemory the run goes on
  // with them held, from the restored multipliers and memory.
  void Handshake(const std::string& scenario_name, double start_time, double step);
  // What the next step starts from (state.proto's CoordinatorMemory), for a restart.
  void SaveMemory(state::CoordinatorMemory* out) const;
  // Restores a SaveMemory of this scene's coupling (before the handshake; the integrator and
  // the data restored with it). The reason a memory is refused (another number of points, sizes
  // that do not match, non-finite values), nothing changed; empty if none.
  std::string RestoreMemory(const state::CoordinatorMemory& in);
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
  Attempt Try(double t, double h);
  void Accept(double t, double h);
  void Reject();
  // Why `attempt` (the last Try's, not converged) did not converge or failed, with the coupling
  // state it left (CouplingState): the message of its NumericalError or rejected step.
  std::string Describe(const Attempt& attempt) const;
  // The interface nodes in contact and the largest force mismatch, for a failed step's reason.
  std::string CouplingState() const;
  long long rejected_steps() const { return rejected_; }
  long long free_flight_steps() const { return free_flight_; }  // steps accepted after one iteration
  // Coupling iterations whose smooth solve failed and were redone with a halved update.
  long long backtracks() const { return backtracks_; }
  // Steps whose linearising pre-solve failed and that took the predictions as the point instead.
  long long linearisation_fallbacks() const { return linearisation_fallbacks_; }
  // Steps whose impacts, left to their ties, had the impacting elastic bodies' acceleration
  // history replaced by the step before's (HoldImpactingBodiesHistory).
  long long impacts_held() const { return impacts_held_; }
  // Steps accepted on the linearising pre-solve: the peers' answer agreed with it (no second solve).
  long long linearisation_accepted() const { return linearisation_accepted_; }
  // Whether the steps iterate with interface Jacobians (every peer offered them).
  bool interface_jacobians() const { return jacobians_; }
  // Tells every peer the run is over (exit code 0, or the failure's code and reason) and, with
  // `wait_for_replies`, waits for each one's Shutdown.
  void Shutdown(int exit_code, const std::string& reason, bool wait_for_replies = true);

  // The iterations of the last step (or of the step under way when it failed).
  const std::vector<CouplingIterationRecord>& log() const { return log_; }
  int last_newton_iterations() const { return newton_; }  // CGα iterations of the last step, all tries
  long long marked_steps() const { return marked_; }
  long long retried_steps() const { return retried_; }  // fixed steps redone as halves (or quarters)
  // Steps accepted with the reaction residual at round-off but above the tolerance.
  long long roundoff_steps() const { return at_roundoff_; }

 private:
  void Impose(double h);  // k → the interface rows' imposed coordinates
  // ṽ → the interface rows' imposed rates, and their accelerations over the step from its start.
  void ImposeRates(double h);
  // CGα from `state` at t, its accelerations with the coupling rows of `points` left out.
  void RestartWithCouplingRowsFree(DaeState state, double t, const std::vector<int>& points);
  // The step-start multipliers of the interface rows (and their filtered values) from `state`.
  void StartReactionsFrom(const DaeState& state);
  // The interface points whose node's contact closed in this step (in contact, not in the last
  // accepted one): impacts.
  std::vector<int> Impacts() const;
  // After an accepted step with impacts at elastic nodes (`impacts` not in `restarted`): their
  // bodies' a_{n+1} and q̈_{n+1} become the step before's (the impulse kept out of CGα's recurrence).
  void HoldImpactingBodiesHistory(const std::vector<int>& impacts, const std::vector<int>& restarted, double t,
                                  double h);
  std::vector<int> BodiesTheImpulseMovedInTheStep(int k, double t, double h) const;
  // A restart at an impact moved the rigid bodies' velocities from `before` (the step's end) to
  // `after` (projected): the nodes of the other points on them take their points' jumps
  // (RestartedNodes in proto/coupling.proto); the imposed rates and the kinematics are updated
  // here, the peers told with the next StepBegin or the Shutdown (FillRestartedNodes).
  void MoveNodesWithRestart(const DaeState& before, const DaeState& after, const std::vector<int>& restarted);
  // After an impact's restart: the bodies whose positions and velocities it did not change take
  // back their acceleration history (`before`, `a_before`: the step's state before the restart).
  void KeepHistoryTheRestartDidNotChange(const DaeState& before, const Eigen::VectorXd& a_before);
  void FillRestartedNodes(const Peer& peer, coupling::RestartedNodes* out) const;
  void ReceiveKinematics(int iteration);
  void EndStep(bool accepted, bool converged);  // StepEnd to every peer, and their replies

  // The stages of a step (Try).
  // Sends StepBegin (iteration 0's reactions: x_, and with interface Jacobians the stiffness
  // and positions of the smooth side's linearisation) and receives the kinematics. The moving
  // obstacles' frames are those of `frames` advanced by `ahead` [s] at their rates.
  void BeginStep(double t, double h, const DaeState& frames, double ahead);
  // Reactions of `iteration` (x_, the frames of `frames`) to every peer, and their kinematics.
  void Exchange(int iteration, const DaeState& frames);
  // Peer q's reactions x_ (and E, k̂) and the frames of `frames` advanced `ahead` (recorded in
  // sent_frames_): the body of a StepBegin's predictor or of a Reactions.
  void FillReactions(size_t q, const DaeState& frames, double ahead, coupling::Reactions* reactions);
  // One CGα solve of the step (from `guess`, or the predictor): iterate_ and x̃ from it; its
  // status (a failed one leaves the integrator at the step's start).
  StepStatus SolveStep(double t, double h, const DaeState* guess);
  // The convergence tests of an iteration (filling the record's residuals).
  bool JacobianConverged(CouplingIterationRecord* record) const;
  bool RelaxationConverged(int iteration, bool free_flight, CouplingIterationRecord* record, bool* skipped);
  // x̃ (and the filtered multipliers) from the integrator's state after a solve.
  void ReactionsFromSolve();
  // Interface Jacobians: the multipliers' share of the reaction sent, x = κ λ + x_c.
  double ReactionPerMultiplier() const;
  Eigen::Vector3d ReactionConstant(int point) const;
  // The peers' affine answer k(x) = k̃ + S (x − x̃) on the interface rows: imposed position
  // k̃ + S (x_c − x̃) and compliance κ S (SystemData); rates and accelerations from ṽ.
  void ImposeModel(double h);
  // The smooth side's linearisation for the peers: stiffness E = ∂x/∂k of each point with its
  // own peer's compliance taken out, from the last factorisation (cached while it lasts).
  void UpdateStiffness(double h);
  // The axes of the body carrying interface point `point` in `state` (identity for an elastic node).
  Eigen::Matrix3d BodyAxes(int point, const DaeState& state) const;
  // How far the moving obstacles' frames at `state` are from those the peers stepped with, at
  // their nodes in contact [m].
  double FrameDrift(const DaeState& state) const;
  // With interface Jacobians: the pre-solve of a step (the smooth side alone, its interface
  // points following the peers' last affine answers from predicted positions) that gives the
  // linearisation point x̂, k̂ sent with StepBegin; if it fails, the predictions are the point.
  void Linearise(double t, double h);
  // The point sent next (x̂, k̂) from the last solve, and the stiffness E there.
  void LineariseAtSolve(double h);
  // Whether the peers' first answer agrees with the pre-solve (x̂, k̂) within the coupling
  // tolerances, so that it is the step's coupled solution as it stands (filling the record).
  bool LinearisationAgrees(CouplingIterationRecord* record) const;
  // The force test of both: `force` within the tolerances of the force the peers held.
  bool ForcesAgree(const Eigen::VectorXd& force) const;

  const MultibodySystem& system_;
  SystemData* data_;
  CgAlpha* integrator_;
  std::vector<Peer> peers_;
  CouplingSettings settings_;
  interface::Relaxation relaxation_;
  CgAlpha::Checkpoint start_;
  DaeState iterate_;  // the end state of the step's last solved coupling iteration (Newton's start for the next)
  bool iterate_solved_ = false;                  // iterate_ is a solve of the step under way
  Eigen::VectorXd held_a_, held_qddot_;          // HoldImpactingBodiesHistory's buffers
  std::vector<int> moved_points_;                // MoveNodesWithRestart's, until the peers are told
  std::vector<Eigen::Vector3d> impact_normals_;  // Accept's impact reactions' directions, one per point
  bool restored_ = false;                        // RestoreMemory: the handshake goes on with the rows held
  bool resting_at_start_ = false;                // a settled start's first step: its contacts rest (Impacts)
  static constexpr int kMaxBacktracks = 4;       // per step (Try)
  // Try's pieces.
  void BeginTry(double h);
  Attempt Failed(int at, Attempt::Outcome outcome, Attempt result);
  Attempt Finished(int last, Attempt result);
  void Backtrack(int iteration, int backtracks);
  long long step_ = 0;
  long long last_accepted_ = -1;
  int n_ = 0;                                                                // interface values: 3 per point
  Eigen::VectorXd x_, x_tilde_, x_next_, accepted_x_, previous_accepted_x_;  // reactions
  Eigen::VectorXd solved_x_;      // the reactions of the step's last coupling iteration that solved
  long long accepted_steps_ = 0;  // since the start or the last impact (for the predictor)
  double accepted_h_ = 0.0;       // the last accepted step's length
  double time_to_contact_ = 0.0;  // the peers' earliest, from the last Kinematics
  int last_iteration_ = 0;        // of the last Try
  long long rejected_ = 0, free_flight_ = 0, backtracks_ = 0;
  // The interface rows' multipliers λ and their CGα-filtered values λ̃ at the step's start
  // (accepted) and end (this iteration).
  Eigen::VectorXd lambda_start_, lambda_end_, filtered_start_, filtered_end_;
  Eigen::VectorXd position_, velocity_, previous_position_, start_velocity_;  // kinematics
  bool in_contact_ = false;                                                   // any interface node, this iteration
  std::vector<bool> contact_, was_contact_;  // per interface point: this iteration, the last accepted step
  std::vector<int> coupling_rows_;           // the interface points' constraint rows
  std::vector<CouplingIterationRecord> log_;
  long long marked_ = 0;
  long long retried_ = 0;
  int StepOrSplit(double t, double h, int depth);
  long long at_roundoff_ = 0;
  Eigen::VectorXd previous_x_tilde_;  // x̃ of the previous iteration
  int newton_ = 0;
  // Interface Jacobians (per interface point): the peers' position and velocity sensitivities,
  // the force they held x̃ (applied_), the stiffness E and positions k̂ sent, the smooth side's
  // response ∂λ/∂x with the compliance it was factorised with, and the peers' compliance in the
  // last factorised matrix.
  bool jacobians_ = false;
  // response_: the point's own stiffness D from the last factorisation, response_axes_: its body's
  // axes then.
  std::vector<Eigen::Matrix3d> sensitivity_, stiffness_, response_, response_axes_;
  // What the peers said at the last accepted step (their sensitivities, contact, time to contact):
  // Reject puts them back, so that a rejected step leaves no trace in the next try.
  std::vector<Eigen::Matrix3d> accepted_sensitivity_;
  bool accepted_in_contact_ = false;
  double accepted_time_to_contact_ = 0.0;
  Eigen::VectorXd applied_, sent_position_;
  Eigen::VectorXd accepted_position_, accepted_velocity_, accepted_acceleration_;
  // The peers' affine law at the last accepted step, k = a + S x (a: accepted_offset_), and the
  // nodes' motion the step before it, for the next step's predicted law (Linearise).
  Eigen::VectorXd accepted_offset_, previous_accepted_position_, previous_accepted_velocity_;
  double previous_accepted_h_ = 0.0;
  bool offset_known_ = false;  // accepted_offset_ and the previous step's motion hold for this law
  long long linearisation_fallbacks_ = 0, linearisation_accepted_ = 0, impacts_held_ = 0;
  long long response_factorizations_ = -1;
  double response_h_ = 0.0;
  // The moving obstacles' frames the peers stepped with (origin, rotation), peer by peer.
  std::vector<std::vector<std::pair<Eigen::Vector3d, Eigen::Matrix3d>>> sent_frames_;
};

}  // namespace cosim::smooth
