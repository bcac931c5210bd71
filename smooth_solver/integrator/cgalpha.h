#pragma once
// Constrained generalised-α (CGα) for the DAE  M q̈ + Φ_qᵀ λ = f,  Φ(q, t) = 0
// [CGα paper, Section 2; Arnold & Brüls 2007], in one of two constraint formulations.
//
//   (1 − αm) a_{n+1} + αm a_n = (1 − αf) q̈_{n+1} + αf q̈_n                     Eq. (3)
//   q_{n+1} = q_n + h q̇_n + h² (½ − β) a_n + h² β a_{n+1}                     Eq. (5)
//   q̇_{n+1} = q̇_n + h (1 − γ) a_n + h γ a_{n+1}
//   M q̈_{n+1} + Φ_qᵀ λ_{n+1} = f_{n+1}                                         Eq. (1)
//
// INDEX3 (the CGα paper, Eq. (2)): Φ(q_{n+1}, t_{n+1}) = 0 closes the step.
// INDEX2_PROJECTED (the default; docs/design.md, "Spinning bodies"): the velocity constraint
//   Φ_q(q_{n+1}) q̇_{n+1} + Φ_t = 0 closes the step (the stabilised index-2 form of Arnold,
//   Brüls & Cardona 2016, whose λ is the velocity-level multiplier), and the positions are then
//   projected back onto Φ(q, t_{n+1}) = 0 along the Newton matrix's own directions,
//     q_{n+1} ← q_{n+1} + δ,  [βh² H, Φ_qᵀ; G, 0] [δ; μ] = [0; −Φ],
//   a correction of the size of one step's drift, O(h³), so the order stays 2. Only curved rows
//   (Φ_q changing with q) take the velocity form; linear rows, and the rows of coupling interface
//   nodes (imposed coordinates, optionally Tikhonov-regularised), stay at position level. The index-3 form leaves the
//   velocity-level form of curved constraints (the rigidity rows u·u = 1, ... of natural coordinates, revolute axes) to
//   the Newmark update, whose normal-velocity mode has the amplification 1 − γ/β ≈ −0.999 at ρ∞ = 0.9: a body spinning
//   at Ωh > 0.04 turns that mode into growth (energy ×1e3 in 2 s at Ωh = 0.3).
//
// with the elastic bodies' internal force in f as the GEMM effective end-point force f̃_{n+1}
// (ElasticStepForce: equivalent to the paper's Eq. (30)),
// solved by Newton–Raphson on (q_{n+1}, λ_{n+1}) with the exact tangent
//   [β' M + γ' C + K_t, Φ_qᵀ; G, 0],  β' = (1 − αm)/((1 − αf) β h²),  γ' = γ/(βh),
//   K_t = ∂(Φ_qᵀλ)/∂q − ∂f/∂q,  C = −∂f/∂q̇,
//   G = Φ_q (position rows) or ∂(Φ_q q̇ + Φ_t)/∂q / γ' = Φ_q + (Φ_q q̇)_q / γ' (velocity rows,
//   divided by γ' so that the matrix keeps Φ_q's scale and sparsity pattern),
// and Bottasso's scaling (Eqs. (34)-(36)): the dynamic rows are multiplied by βh² and the
// multiplier unknowns divided by it, which makes the matrix O(1) as h → 0.
//
// Coefficients from ρ∞ ∈ [0, 1] (Chung & Hulbert, as used by Arnold & Brüls):
//   αm = (2ρ∞ − 1)/(ρ∞ + 1), αf = ρ∞/(ρ∞ + 1), γ = ½ + αf − αm, β = ¼ (γ + ½)².
// Starting value: a_0 = q̈(t_0 + Δα h), Δα = αm − αf, as Arnold & Brüls prescribe for smooth
// solutions, from the consistent accelerations after one trapezoidal step of length Δα h (a
// Taylor shift would blow up stiff elastic modes; see Step). Measured (index 3): the multipliers
// still show a period-2 start-up transient (four-bar,
// ρ∞ = 0.95, h = 1e-3: up to 1.4e-2 N on the 24 N joint force after 20 steps, decaying over
// ~150 steps), which the shifted a_0 changes only in the fifth digit; and a drive whose jerk
// jumps at t_0 (the cosine spin-up ramp) gives an O(h) transient in the drive torque.
// (The CGα paper's Eq. (4) prints αm and αf the other way round; with its own γ = ½ − αm + αf
// that would give γ < ½ for ρ∞ < 1, an unstable scheme, so the names there are swapped.)
#include <Eigen/Core>
#include <cmath>
#include <string>
#include <vector>

#include "smooth_solver/integrator/elastic_step_force.h"
#include "smooth_solver/integrator/smooth_integrator.h"
#include "smooth_solver/linear_algebra/klu_solver.h"

namespace cosim::smooth {

// Generalised-α coefficients from ρ∞ (Chung & Hulbert; Arnold & Brüls).
struct AlphaCoefficients {
  double alpha_m, alpha_f, gamma, beta;
  static AlphaCoefficients FromRhoInf(double rho_inf) {
    const double am = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0), af = rho_inf / (rho_inf + 1.0);
    const double g = 0.5 + af - am;
    return {am, af, g, 0.25 * (g + 0.5) * (g + 0.5)};
  }
};

// Whether two step lengths are the same step: equal up to the round-off of t_{k+1} − t_k on a
// run's time grid (~1e-15 relative), which decides whether a matrix or a law made for one serves
// the other.
inline bool SameStepLength(double a, double b) { return std::abs(a - b) <= 1e-9 * a; }

// Which form of the constraints closes a step (see the top of this file).
enum class ConstraintForm {
  kIndex3,           // Φ(q) = 0: the CGα paper
  kIndex2Projected,  // Φ_q q̇ + Φ_t = 0, then the positions projected onto Φ(q) = 0
};

struct CgAlphaSettings {
  double rho_inf = 0.9;  // ρ∞ ∈ [0, 1]; 1 = no numerical dissipation
  ConstraintForm form = ConstraintForm::kIndex2Projected;
  double tolerance = 1e-6;  // on |Δq|∞ (relative to 1 + |q|∞) and |Φ|∞
  int max_iterations = 20;
  // Elastic bodies: the GEMM midpoint internal force (Eq. (30)); false: the generalised-α
  // end-point force of Eq. (12).
  bool gemm = true;
  // Newton matrix reuse (a modified Newton method): the matrix and its factorisation may serve
  // up to this many later steps of the same h (0: a fresh matrix in every iteration, full
  // Newton). A reused matrix is dropped when an iteration contracts the correction by less than
  // `reuse_contraction` (the step then goes on with a fresh one) or when the step fails with it
  // (the step is redone from its predictor with fresh matrices), so only the number of
  // iterations changes, never the test that accepts a step.
  int jacobian_max_age = 0;
  double reuse_contraction = 0.25;
  // With reuse on (jacobian_max_age > 0), the rigid body (index into the model's bodies, -1:
  // none) whose rotation a reused matrix is carried along with: a co-rotated reuse. Every
  // coordinate of the system is a 3-vector (positions, body axes, nodes, beam directors), and for
  // a scene symmetric about the motion of this body (a rotor about its shaft: the hub) the Newton
  // matrix at a rotated state is the rotated matrix, S(Rq) = T S(q) Tᵀ with T rotating every
  // coordinate triple and the multiplier triples of ConstraintSet::vector_triples by R. A matrix
  // factorised when the body's axes were F₀ then serves the state with axes F as
  // x = T S₀⁻¹ Tᵀ b, R = F F₀ᵀ: in absolute coordinates a blade's stiff axial modes turn with it,
  // and an unrotated matrix stops contracting once the hub has turned by about the ratio of its
  // bending to axial stiffness (1e-3 rad on the four-blade hub of elastic_benchmark). The peers'
  // compliance on coupling interface rows stays out of the matrix (Woodbury, in its axes).
  int frame_body = -1;
};

// How a CGα step went: its outcome and statistics (in the spirit of Drake's SapSolverStatus). A
// failed step leaves the integrator's state as it was; Describe says why in words for a run's
// reason. Only the callers that end a run turn a failed status into an error (Step does, for
// those with nothing else to try); the adaptive controller and the coupling back-track on it.
struct StepStatus {
  enum class Outcome {
    kConverged,
    kNotConverged,         // max_iterations without meeting the tolerances
    kNonFiniteCorrection,  // a Newton correction was not finite
    kDiverged,             // the iteration matrix stopped being finite (at failed_iteration)
    kProjectionFailed,     // INDEX2_PROJECTED: the position projection did not converge
    kNonFiniteSolution,    // converged positions with non-finite multipliers or rates
    kSingularMatrix,       // the iteration matrix is singular (a model fault, not the step's)
  };
  Outcome outcome = Outcome::kConverged;
  int iterations = 0;        // Newton iterations, over every try of the step
  double time = 0.0;         // the step's end t + h [s]
  int failed_iteration = 0;  // kDiverged
  double violation = 0.0;    // kProjectionFailed: |Φ| left
  int solves = 0;            // kProjectionFailed: projection solves done
  bool ok() const { return outcome == Outcome::kConverged; }
  std::string Describe(const CgAlphaSettings& settings) const;
  // The words of a step that still failed as `pieces` steps of h from t (a fixed step retried as
  // halves and quarters, coupled or not): `why` without its advice to reduce the step.
  static std::string AfterRetries(std::string why, int pieces, double h, double t);
  static constexpr int kRetrySplits = 2;  // a failed fixed step is retried as halves, then quarters
};

class CgAlpha : public SmoothIntegrator {
 public:
  // `initial` must be consistent (positions, velocities, accelerations, multipliers). `data`: the
  // run's changing state (MakeData(system), owned by the caller, outliving the integrator), which
  // every evaluation reads and the checkpoints save and restore.
  CgAlpha(const MultibodySystem& system, SystemData* data, const CgAlphaSettings& settings, const DaeState& initial);

  // Advances from t to t + h. Returns the Newton iterations used; throws NumericalError if
  // Newton does not converge (state unchanged).
  int Step(double t, double h) override { return Step(t, h, nullptr); }
  IntegratorCapabilities capabilities() const override { return {.checkpoints = true, .error_estimate = true}; }
  // The same, with Newton started from `guess` instead of the predictor: the end state of an
  // earlier solve of this very step (same start state and h, e.g. the last coupling iteration,
  // whose imposed coordinates have changed a little since), which satisfies the step's Newmark
  // relations between q, q̇ and q̈ as the predictor does.
  int Step(double t, double h, const DaeState* guess);
  // The same without throwing: the step's status (state advanced only if it converged). A
  // coupled step's `motion` (the peers' imposed coordinates at its end, this try's) is taken
  // into the data first; null: the data's as they are (a standalone run's, or a try of the
  // same input).
  [[nodiscard]] StepStatus TryStep(double t, double h, const DaeState* guess = nullptr,
                                   const InterfaceMotion* motion = nullptr);
  const CgAlphaSettings& settings() const { return settings_; }

  const DaeState& state() const override { return state_; }
  double alpha_m() const { return coef_.alpha_m; }
  double alpha_f() const { return coef_.alpha_f; }
  double beta() const { return coef_.beta; }
  double gamma() const { return coef_.gamma; }
  // The acceleration-like variable a_n of Eq. (3) (the adaptive step's error estimate).
  const Eigen::VectorXd& acceleration_variable() const { return a_; }
  // |Φ|∞ at the current state.
  double ConstraintViolation(double t) const override;
  // Solves of the position projection over all steps so far (INDEX2_PROJECTED; cost accounting).
  long long projection_solves() const { return projection_solves_; }
  // Newton matrices assembled and factorised over all steps so far (cost accounting; with
  // jacobian_max_age = 0 one per Newton iteration).
  long long factorizations() const { return factorizations_; }
  // Entries of the Newton matrix's LU factors (KluSolver::factor_entries).
  long factor_entries() const { return lu_.factor_entries(); }
  // With the last factorised Newton matrix, at the present state: ∂λ/∂x of interface point k's
  // multipliers with respect to its imposed position x (3 × 3), the smooth model's own (the
  // peers' compliance, SystemData::interface_compliance, taken out) — the smooth side's interface
  // stiffness (interface Jacobians). Needs a factorisation of step h (some step has been taken).
  Eigen::Matrix3d InterfaceResponse(int k, double h);
  bool has_factorization() const { return factorized_; }

  // Starts again from `state` (consistent), a_n = q̈_n, without the shifted start-up: for a
  // coupled run, where the imposed coordinates are end-of-step values and a shift step would
  // impose them at the wrong time.
  void Restart(const DaeState& state) {
    state_ = state;
    a_ = state.qddot;
    elastic_.Reset(state.q);
    started_ = true;
  }

  // Replaces the last step's acceleration history, a_{n+1} and q̈_{n+1}, keeping its positions,
  // velocities and multipliers: the coupling's way to keep an impact's impulse out of Eq. (3)'s
  // recurrence (Coordinator::Accept).
  void ReplaceAccelerationHistory(const Eigen::VectorXd& a, const Eigen::VectorXd& qddot) {
    a_ = a;
    state_.qddot = qddot;
  }

  // Everything a step changes, to try a step again (a coupling iteration) or undo it (a
  // rejected step): the integrator's state and the run's SystemData (imposed interface
  // coordinates, contact memories, inflow). SaveTo reuses the checkpoint's buffers.
  struct Checkpoint {
    DaeState state;
    Eigen::VectorXd a, elastic;
    bool started = false;
    SystemData data;
  };
  void SaveTo(Checkpoint* c) const {  // assignments of equal sizes reuse the buffers
    c->state = state_;
    c->a = a_;
    c->elastic = elastic_.current();
    c->started = started_;
    if (c->data.SameShape(*data_)) {
      c->data.CopyFrom(*data_);
    } else {
      c->data = *data_;  // the first save: allocates
    }
  }
  void Restore(const Checkpoint& c) {
    state_ = c.state;
    a_ = c.a;
    elastic_.set_current(c.elastic);
    started_ = c.started;
    data_->CopyFrom(c.data);
  }

 private:
  // Zeroes S_, adds the elastic tangent and f̃ (into force_), then the rest of the matrix.
  void AssembleIteration(double t1, double h);
  // rows_ at next_: Φ − cλ on position rows (c: Tikhonov regularisation), Φ_q q̇ + Φ_t on
  // velocity rows; `phi_known`: phi_ holds Φ(next_.q) already.
  void ConstraintRows(double t1, bool phi_known);
  // out = rows_ with the velocity rows × velocity_scale (1/γ' in the residual, h in the
  // convergence test); returns |out|∞.
  double ScaledRows(double velocity_scale, Eigen::Ref<Eigen::VectorXd> out) const;
  // INDEX2_PROJECTED: projects next_.q onto Φ(q, t1) = 0 on the velocity rows: each beam node's
  // axes onto the nearest orthonormal ones (OrthonormaliseBeamNodes), the other rows with the last
  // factorisation (a chord iteration); false (and *status says how far it got) if it does not
  // converge.
  [[nodiscard]] bool ProjectPositions(double t1, StepStatus* status);
  // next_.q's beam-node axes A ← U Vᵀ (A = U Σ Vᵀ): the closest orthonormal axes, which close the
  // node's six rigidity rows exactly.
  void OrthonormaliseBeamNodes();

  const MultibodySystem& system_;
  SystemData* data_;  // the run's changing state (the constructor's `data`), saved with the checkpoints
  CgAlphaSettings settings_;
  AlphaCoefficients coef_;
  DaeState state_;
  Eigen::VectorXd a_;         // acceleration-like variable a_n
  ElasticStepForce elastic_;  // f̃_n of the elastic bodies
  bool started_ = false;
  // Per constraint row: 1 where the velocity form closes the step (INDEX2_PROJECTED: the curved
  // rows but the coupling rows; VelocityLevelRow in cgalpha.cpp), 0 where Φ itself does.
  std::vector<char> velocity_row_;
  bool any_velocity_row_ = false;
  // INDEX2_PROJECTED: the beam nodes (bodies) whose axes ProjectPositions orthonormalises, and per
  // row 1 for their rigidity rows, which that closes (the chord solves leave them out).
  std::vector<int> beam_nodes_;
  std::vector<char> beam_node_row_;
  long long projection_solves_ = 0;
  long long factorizations_ = 0;
  // The factorisation in lu_: valid for step h_factorized_, reused for age_ accepted steps.
  bool factorized_ = false;
  double h_factorized_ = 0.0;
  int age_ = 0;
  // Which Newton matrices a solve of the step uses: the factorisation in lu_ from an earlier
  // step (then fresh ones if it stops contracting), a fresh one in the first iteration kept for
  // the later ones while they contract well (modified Newton), or a fresh one in every iteration.
  enum class Matrices { kReused, kFreshFirst, kFreshEach };
  // One Newton solve of the step from its predictor (next_ set): status->outcome says how it
  // ended; the iterations are added to status->iterations.
  void Newton(double t1, double h, Matrices matrices, StepStatus* status);
  // x ← S⁻¹ x with the factorisation in lu_, co-rotated with settings_.frame_body (see there)
  // from its axes when the matrix was assembled to their value at next_.q.
  void Solve(Eigen::Ref<Eigen::VectorXd> x);
  // The peers' compliance on the interface rows without factorising it (docs/protocol.md,
  // "Interface Jacobians"): Woodbury's identity over the 3 × points interface columns
  // J⁻¹P = Y, W = PᵀY, made once per factorisation (in the factorised axes with co-rotated
  // reuse; `to_factorized` turns today's compliance into them).
  void FactorizeInterfaceColumns();
  void AddComplianceCorrection(Eigen::Ref<Eigen::VectorXd> x, const Eigen::Matrix3d& to_factorized);
  bool woodbury_ = false;
  Eigen::MatrixXd woodbury_y_, woodbury_w_, woodbury_c_;
  Eigen::VectorXd woodbury_g_;
  void SolveAt(Eigen::Ref<Eigen::VectorXd> x, const Eigen::VectorXd& q);  // co-rotated to q's frame axes
  Eigen::Matrix3d FrameAxes(const Eigen::VectorXd& q) const;
  // R = F F₀ᵀ: the frame body's turn from its axes when the matrix was factorised to q's
  // (identity without co-rotated reuse).
  Eigen::Matrix3d TurnSinceFactorized(const Eigen::VectorXd& q) const;
  Eigen::Matrix3d factorized_axes_ = Eigen::Matrix3d::Identity();
  // Newton workspace.
  DaeState next_, predicted_;
  Eigen::VectorXd a_next_, residual_, delta_, phi_, phi_t_, rate_, rows_, violation_step_, force_;
  mutable Eigen::VectorXd violation_;
  Eigen::SparseMatrix<double> S_;
  KluSolver lu_;
};

// Consistent accelerations and multipliers at (q, q̇, t): [M Φ_qᵀ; Φ_q 0][q̈; λ] = [f; −ξ].
// Throws InputError if the matrix is singular (redundant constraints or a free body with a
// singular mass matrix).
// `free_rows` (optional): constraint rows left out (their λ = 0), e.g. the coupling rows at the
// start of a coupled run, whose imposed accelerations nobody knows yet.
void ConsistentAccelerations(const MultibodySystem& system, const SystemData& data, double t, DaeState* state,
                             const std::vector<int>* free_rows = nullptr);

// If a locked joint lets go between t and t1, the equations change and the accelerations,
// multipliers and α history belong to the old ones: recompute q̈ and λ of `state` for the new
// equations (just after the release) and return true, so the caller restarts its history.
bool RestartAtRelease(const MultibodySystem& system, const SystemData& data, double t, double t1, DaeState* state);

}  // namespace cosim::smooth
