#pragma once
// A coupling method: how the iterations of a coupled step (rotor-sailing paper, Section 2) reach
// agreement between the smooth model and the contact processes. The coordinator runs the step
// (the checkpoint, the smooth solves, the messages); the method says what the smooth side is
// solved with (Impose), whether the two sides agree (Converged) and what is sent next (Next).
// Two methods: interface Jacobians (interface_jacobian_method.h, the default when every peer
// offers them: a Newton iteration on the interface) and a relaxation of the reactions
// (relaxation_method.h: constant, Aitken or IQN-ILS).
#include <string>
#include <vector>

#include "interface/coupling/relaxation.h"
#include "smooth_solver/coupling/coupling_memory.h"
#include "smooth_solver/coupling/peer_link.h"
#include "smooth_solver/integrator/cgalpha.h"
#include "smooth_solver/model/multibody_system.h"

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
  bool step_average_reaction = false;  // false: λ at the step's end (see proto/scenario/coupling.proto)
  bool stop_at_max_iterations = true;  // false: accept and mark the step
  bool restart_at_impact = true;       // see proto/scenario/coupling.proto, CouplingIteration
  bool warm_start = true;              // Newton from the last coupling iteration's end (proto/scenario/coupling.proto)
  // Interface Jacobians (docs/protocol.md) with every peer that offers them: the peers take the
  // smooth side's linearisation as an implicit force law and answer with their sensitivities,
  // which the smooth step takes as a compliance on the interface rows (a Newton iteration on
  // the interface). false: the relaxation above with every peer.
  bool interface_jacobians = true;
  // Interface Jacobians: a step whose peers' first answer agrees with the linearising pre-solve
  // is accepted on it, without a second smooth solve (proto/scenario/coupling.proto,
  // CouplingIteration.accept_agreeing_linearisation).
  bool accept_agreeing_linearisation = true;
  // > 0: a step whose peers report no contact within this many steps of its end is accepted
  // after its first iteration if the reaction residual meets the tolerance (proto/scenario/coupling.proto,
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

// The interface's values in the step under way, per interface value (3 per point): what the
// coordinator sent, what the smooth side answered and what the peers answered. The coordinator
// writes x̃ (each solve) and the answers (each exchange); the method reads them and sets x.
struct CouplingIterate {
  explicit CouplingIterate(int points);
  Eigen::VectorXd x;        // the reactions sent with the last StepBegin or Reactions [N]
  Eigen::VectorXd x_tilde;  // x̃: the smooth model's reactions on the nodes after the last solve [N]
  PeerAnswers answers;      // the peers' last Kinematics (with interface Jacobians: their affine law)
};

// The interface rows' imposed motion (SystemData::imposed: p(q) − k − cλ = 0 per interface value)
// for a solve of the step.
class InterfaceRows {
 public:
  explicit InterfaceRows(SystemData* data) : data_(data), motion_{data->imposed, data->interface_compliance} {}
  // The step's start (the data as a checkpoint holds it): the rates its imposed accelerations
  // are measured from.
  void BeginStep(int values);
  // Into this try's motion, the solve's input: position value v, the compliance C of point k,
  // and the rates `velocity` with their accelerations over the step of length h from its start.
  void SetPosition(Eigen::Index v, double position) { motion_.imposed[static_cast<size_t>(v)].value = position; }
  void SetCompliance(size_t k, const Eigen::Matrix3d& compliance) { motion_.compliance[k] = compliance; }
  void SetRates(const Eigen::VectorXd& velocity, double h);
  const InterfaceMotion& motion() const { return motion_; }
  // A pre-solve that stands as the step's solve: `velocity` (the peers' answer) and its
  // accelerations into the solved step's data, as its rates.
  void SetSolvedRates(const Eigen::VectorXd& velocity, double h);

 private:
  SystemData* data_;
  InterfaceMotion motion_;
  Eigen::VectorXd start_velocity_;
};

// What the smooth side's answer x̃ is made of: the interface rows' multipliers λ at the step's
// end (END_OF_STEP), or their CGα-filtered values averaged over the step (STEP_AVERAGE;
// proto/scenario/coupling.proto, CouplingIteration.step_average_reaction).
class StepReaction {
 public:
  StepReaction(const MultibodySystem& system, const CgAlpha& integrator, bool step_average);
  // λ and λ̃ at the step's start from `state`'s multipliers (a start, or a restart).
  void StartFrom(const DaeState& state, CouplingMemory* memory) const;
  // x̃ of a solve whose end multipliers are `lambda`.
  void FromSolve(const Eigen::VectorXd& lambda, const CouplingMemory& memory, Eigen::VectorXd* x_tilde);
  // The accepted step's end is the next step's start.
  void Accept(CouplingMemory* memory) const;
  // x̃ = κ λ₁ + x_c per point: κ, and x_c of point `point`.
  [[nodiscard]] double PerMultiplier() const;
  [[nodiscard]] Eigen::Vector3d Constant(int point, const CouplingMemory& memory) const;

 private:
  const MultibodySystem& system_;
  const CgAlpha& integrator_;
  bool step_average_;
  Eigen::VectorXd lambda_end_, filtered_end_;  // λ and λ̃ at the end of the last solve
};

class CouplingMethod {
 public:
  virtual ~CouplingMethod() = default;
  // The step's start (x predicted by the coordinator).
  virtual void BeginStep() = 0;
  // Whether the step begins with a pre-solve of the smooth side alone (interface Jacobians'
  // linearisation): then Predict before it, Linearised after it.
  [[nodiscard]] virtual bool PreSolves() const = 0;
  // The peers' answers predicted for the pre-solve (their last law carried on).
  virtual void Predict(double h) = 0;
  // After the pre-solve (`solved`: it converged; the integrator holds it): the point sent with
  // StepBegin.
  virtual void Linearised(double h, bool solved) = 0;
  // After StepBegin's answer: whether the pre-solve `solved` stands as the step's coupled solution
  // (filling `record`).
  [[nodiscard]] virtual bool PredictionAgrees(bool solved, CouplingIterationRecord* record) = 0;
  // Whether no contact can close in the step of length h (the first iteration may be accepted
  // without its confirmation: free_flight_margin).
  [[nodiscard]] virtual bool FreeFlight(double h) const = 0;
  // The interface rows' motion for the iteration's solve.
  virtual void Impose(double h) = 0;
  // Whether the iteration's solve starts from the last one's end.
  [[nodiscard]] virtual bool WarmStart(int iteration) const = 0;
  // After a solve: whether the two sides agree (filling `record`; `skipped`: accepted without its
  // confirming iteration, free_flight).
  [[nodiscard]] virtual bool Converged(int iteration, bool free_flight, CouplingIterationRecord* record,
                                       bool* skipped) = 0;
  // The reactions x of the next iteration (filling the record's factor).
  virtual void Next(double h, CouplingIterationRecord* record) = 0;
  // The solve of iteration `iteration` failed: x of a retry from the last iteration that solved
  // (`backtrack`: this step's count, this one included), or false: the step has failed.
  [[nodiscard]] virtual bool Backtrack(int iteration, int backtrack, CouplingIterationRecord* record) = 0;
  // The force the peers held in the last exchange.
  [[nodiscard]] virtual const Eigen::VectorXd& HeldForce() const = 0;
  // What the method learnt of the interface map no longer holds (a rejected step, an impact's
  // restart).
  virtual void Forget() = 0;
  // Its own part of a saved state, and its restore (the reason it is refused; empty if none).
  virtual void WriteMemory(state::CoordinatorMemory* out) const = 0;
  [[nodiscard]] virtual std::string ReadMemory(const state::CoordinatorMemory& in) = 0;

  // Steps accepted with the reaction residual at round-off but above the tolerance; steps whose
  // pre-solve failed (its predictions then the point); steps accepted on their pre-solve.
  long long roundoff_steps() const { return roundoff_steps_; }
  long long linearisation_fallbacks() const { return linearisation_fallbacks_; }
  long long linearisation_accepted() const { return linearisation_accepted_; }

 protected:
  long long roundoff_steps_ = 0, linearisation_fallbacks_ = 0, linearisation_accepted_ = 0;
};

}  // namespace cosim::smooth
