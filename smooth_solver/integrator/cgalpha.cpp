#include "smooth_solver/integrator/cgalpha.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>

#include "interface/base/errors.h"
#include "smooth_solver/linear_algebra/fixed_pattern_matrix.h"
#include "smooth_solver/linear_algebra/hub_columns.h"

namespace cosim::smooth {

namespace {

// Sparsity pattern of [A, Φ_qᵀ; Φ_q, 0] where A holds M and the constraint Hessians.
Eigen::SparseMatrix<double> SaddlePattern(const MultibodySystem& system, const SystemData& data) {
  const int n = system.coordinates, m = system.constraints.size();
  PatternSink pattern;
  AddSparse(system.mass, 0.0, &pattern);
  system.constraints.HessianPattern(&pattern);
  system.ForcePattern(&pattern);
  // t = −∞: every row active (a locked joint's row exists until its release).
  const double always = -std::numeric_limits<double>::infinity();
  system.constraints.Jacobian(data.imposed, system.q0, always, &pattern, n, 1.0);
  system.constraints.JacobianTranspose(data.imposed, system.q0, always, &pattern, n, 1.0);
  for (int i = 0; i < n + m; ++i) pattern.Add(i, i, 0.0);  // keep the diagonal structurally present
  // An interface point's rows: the 3 × 3 block of the peer's compliance (interface Jacobians).
  for (const InterfacePoint& p : system.interface_points) {
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) pattern.Add(n + p.first_row + r, n + p.first_row + c, 0.0);
    }
  }
  return pattern.Build(n + m, n + m);
}

// A Newton iterate from a reused matrix is accepted when its estimated error is below this share
// of the Newton tolerance (CgAlpha::Newton).
constexpr double kReusedErrorShare = 1e-3;

// Whether row c is one of a beam node's six rigidity rows (u·u = 1, u·v = 0, ...): every term a
// dot product of two directions of that one node, with no constant vector.
bool BeamNodeRigidityRow(const ScalarConstraint& c, const std::vector<char>& beam_node) {
  int body = -1;
  for (const auto& term : c.terms) {
    for (const LinearVector* v : {&term.a, &term.b}) {
      if (v->terms.empty() || !v->constant.isZero(0.0)) return false;
      for (const auto& t : v->terms) {
        const int b = t.offset / kCoordinatesPerBody;
        const bool direction = t.offset % kCoordinatesPerBody >= 3;
        if (!direction || b >= static_cast<int>(beam_node.size()) || beam_node[static_cast<size_t>(b)] == 0) {
          return false;
        }
        if (body >= 0 && b != body) return false;
        body = b;
      }
    }
  }
  return body >= 0;
}

// Whether INDEX2_PROJECTED closes row i at velocity level: a curved row (a term whose two
// vectors both move: Φ_q changes with q, like the rigidity rows u·u = 1 and the axes of a
// revolute joint between two bodies), unless it is a coupling interface row (imposed by a peer,
// rotor-sailing paper Eq. (6), or Tikhonov-regularised, Eq. (7)). A linear row (a point
// coincidence along fixed axes, an elastic clamp, an axis against the ground) keeps Φ = 0: its
// normal never turns, so the Newmark update's normal-velocity mode (amplification 1 − γ/β,
// |·| < 1 for ρ∞ < 1) stays damped, and index 3 is exact for it.
bool VelocityLevelRow(const ConstraintSet& cs, size_t i) {
  if (cs.Compliance(i) != 0.0) return false;
  const ScalarConstraint& c = cs.constraints[i];
  auto imposed = [&](const DriveWeight& w) {
    return w.drive >= 0 && cs.drives[static_cast<size_t>(w.drive)].imposed >= 0;
  };
  if (imposed(c.constant_weight)) return false;
  bool curved = false;
  for (const auto& term : c.terms) {
    if (imposed(term.weight)) return false;
    curved = curved || (!term.a.terms.empty() && !term.b.terms.empty());
  }
  return curved;
}

}  // namespace

void ConsistentAccelerations(const MultibodySystem& system, const SystemData& data, double t, DaeState* state,
                             const std::vector<int>* free_rows) {
  const int n = system.coordinates, m = system.constraints.size();
  Eigen::SparseMatrix<double> A = SaddlePattern(system, data);
  MatrixSink sink(&A);
  AddSparse(system.mass, 1.0, &sink);
  system.constraints.Jacobian(data.imposed, state->q, t, &sink, n, 1.0);
  system.constraints.JacobianTranspose(data.imposed, state->q, t, &sink, n, 1.0);
  system.constraints.AddReleasedDiagonal(t, &sink, n);
  Eigen::VectorXd rhs(n + m);
  system.Force(state->q, state->qdot, t, data, rhs.head(n));
  system.constraints.AccelerationBias(data.imposed, state->q, state->qdot, t, rhs.tail(m));
  rhs.tail(m) *= -1.0;
  // Rows left out (`free_rows`): an identity row and column, λ_i = 0. Regularised rows
  // (Φ_i − c_i λ_i = 0, Eq. (7) of the rotor-sailing paper): λ_i = Φ_i / c_i is a function of
  // the positions, so their row is −c_i λ_i = −Φ_i, without an acceleration condition.
  enum class Row : unsigned char { kKept, kFree, kCompliant };
  std::vector<Row> mode(static_cast<size_t>(n + m), Row::kKept);
  bool special = false;
  for (int i = 0; i < m; ++i) {
    if (system.constraints.Compliance(static_cast<size_t>(i)) != 0.0)
      mode[static_cast<size_t>(n + i)] = Row::kCompliant, special = true;
  }
  if (free_rows != nullptr) {
    for (int i : *free_rows) mode[static_cast<size_t>(n + i)] = Row::kFree, special = true;
  }
  if (special) {
    Eigen::VectorXd phi(m);
    system.constraints.Evaluate(data.imposed, state->q, t, phi);
    for (int k = 0; k < A.outerSize(); ++k) {
      for (Eigen::SparseMatrix<double>::InnerIterator it(A, k); it; ++it) {
        const Row r = mode[static_cast<size_t>(it.row())], c = mode[static_cast<size_t>(it.col())];
        const bool diagonal = it.row() == it.col();
        if (r == Row::kFree || c == Row::kFree) {
          it.valueRef() = diagonal ? 1.0 : 0.0;
        } else if (r == Row::kCompliant) {
          it.valueRef() = diagonal ? -system.constraints.Compliance(static_cast<size_t>(it.row() - n)) : 0.0;
        }
      }
    }
    for (int i = 0; i < m; ++i) {
      if (mode[static_cast<size_t>(n + i)] == Row::kFree) rhs(n + i) = 0.0;
      if (mode[static_cast<size_t>(n + i)] == Row::kCompliant) rhs(n + i) = -phi(i);
    }
  }
  KluSolver lu;
  if (!FactorizeHubLast(&A, system.rigid_coordinates(), &lu)) {
    throw InputError(
        "model: the constrained mass matrix [M, Φ_qᵀ; Φ_q, 0] is singular at the initial state: the joints are "
        "redundant (an overconstrained loop: e.g. a planar four-bar of four revolute joints in 3D; use a spherical "
        "and a universal joint for two of them) or a body's motion is not constrained nor given inertia");
  }
  Eigen::VectorXd x = rhs;
  lu.SolveInPlace(x);
  state->qddot = x.head(n);
  state->lambda = x.tail(m);
}

bool RestartAtRelease(const MultibodySystem& system, const SystemData& data, double t, double t1, DaeState* state) {
  const double release = system.constraints.ReleaseWithin(t, t1);
  if (!std::isfinite(release)) return false;
  ConsistentAccelerations(system, data, std::max(t, std::nextafter(release, INFINITY)), state);
  return true;
}

CgAlpha::CgAlpha(const MultibodySystem& system, SystemData* data, const CgAlphaSettings& settings,
                 const DaeState& initial)
    : system_(system),
      data_(data),
      settings_(settings),
      coef_(AlphaCoefficients::FromRhoInf(settings.rho_inf)),
      state_(initial),
      elastic_(system, settings.gemm, coef_.alpha_f) {
  a_ = state_.qddot;  // a_0 = q̈_0
  elastic_.Reset(state_.q);
  const int n = system.coordinates, m = system.constraints.size();
  next_ = state_;
  predicted_ = state_;
  a_next_.resize(n);
  residual_.resize(n + m);
  force_.resize(n);
  delta_.resize(n + m);
  phi_.resize(m);
  violation_step_.resize(m);
  phi_t_.resize(m);
  rate_.resize(m);
  rows_.resize(m);
  velocity_row_.assign(static_cast<size_t>(m), 0);
  beam_node_row_.assign(static_cast<size_t>(m), 0);
  if (settings.form == ConstraintForm::kIndex2Projected) {
    const int bodies = system.coordinates / kCoordinatesPerBody;
    std::vector<char> beam_node(static_cast<size_t>(bodies), 0);
    for (const auto& nodes : system.beam_node_bodies) {
      for (int b : nodes) {
        beam_node[static_cast<size_t>(b)] = 1;
        beam_nodes_.push_back(b);
      }
    }
    for (int i = 0; i < m; ++i) {
      const size_t r = static_cast<size_t>(i);
      velocity_row_[r] = VelocityLevelRow(system.constraints, r) ? 1 : 0;
      any_velocity_row_ = any_velocity_row_ || velocity_row_[r] != 0;
      beam_node_row_[r] =
          velocity_row_[r] != 0 && BeamNodeRigidityRow(system.constraints.constraints[r], beam_node) ? 1 : 0;
    }
  }
  woodbury_ = !system.interface_points.empty();
  // (Φ_q q̇)_q has the coordinates of Φ_q in every row: the pattern is the index-3 one.
  S_ = SaddlePattern(system, *data);
  // Once: the pattern never changes. A hub's coordinates (a rotor's) ordered last.
  const int rigid = system.rigid_coordinates();
  lu_.Analyze(S_, HubColumns(S_, RigidBodyGroups(rigid, static_cast<int>(S_.cols()))));
}

double CgAlpha::ConstraintViolation(double t) const {
  violation_.resize(system_.constraints.size());  // sized once
  system_.constraints.Evaluate(data_->imposed, state_.q, t, violation_);
  return violation_.size() > 0 ? violation_.lpNorm<Eigen::Infinity>() : 0.0;
}

void CgAlpha::AssembleIteration(double t1, double h) {
  const int n = system_.coordinates;
  const double bh2 = coef_.beta * h * h;
  // Bottasso scaling: dynamic rows × βh², multiplier columns ÷ βh² (Eqs. (34)-(36)).
  for (int k = 0; k < S_.nonZeros(); ++k) S_.valuePtr()[k] = 0.0;
  MatrixSink sink(&S_);
  // The elastic force and its tangent in one pass (force_ holds the other forces already).
  elastic_.Add(state_.q, next_.q, force_, bh2, &sink);
  AddSparse(system_.mass, (1.0 - coef_.alpha_m) / (1.0 - coef_.alpha_f), &sink);         // βh² β' M
  system_.constraints.HessianTimesLambda(data_->imposed, t1, next_.lambda, &sink, bh2);  // βh² Σ λ_i ∂²φ_i/∂q²
  // βh² (K + γ' C) of the force elements, γ' = γ/(βh): ∂q̇/∂q along the Newton correction.
  system_.AddForceTangent(next_.q, next_.qdot, t1, *data_, bh2, bh2 * coef_.gamma / (coef_.beta * h), &sink,
                          /*include_elastic=*/false);
  system_.constraints.JacobianTranspose(data_->imposed, next_.q, t1, &sink, n, 1.0);
  system_.constraints.Jacobian(data_->imposed, next_.q, t1, &sink, n, 1.0);
  if (any_velocity_row_) {
    // Velocity rows: ∂(Φ_q q̇ + Φ_t)/∂q_{n+1} / γ' = Φ_q + (Φ_q q̇ + Φ_t)_q / γ' (q̇ moves with
    // γ' Δq along the Newton correction).
    system_.constraints.VelocityConstraintJacobian(data_->imposed, next_.q, next_.qdot, t1, &sink, n,
                                                   coef_.beta * h / coef_.gamma, &velocity_row_);
  }
  system_.constraints.AddReleasedDiagonal(t1, &sink, n);  // released rows: Δλ = 0
  // Regularised rows Φ_i − c_i λ_i (Eq. (7) of the rotor-sailing paper): −c_i ∂λ/∂λ̂ = −c_i/(βh²).
  system_.constraints.AddComplianceDiagonal(&sink, n, 1.0 / bh2);
  // The peers' compliance on the interface rows (interface Jacobians), −C/(βh²) likewise, is not
  // in the matrix: Woodbury's identity adds it to every solve (SolveAt), so that a change of the
  // peers' contact sets needs no new factorisation.
}

void CgAlpha::FactorizeInterfaceColumns() {
  // Y = J⁻¹ P (P: the interface rows' unit columns) and W = Pᵀ Y, once per factorisation.
  const int n = system_.coordinates, m = system_.constraints.size();
  const int points = static_cast<int>(system_.interface_points.size());
  woodbury_y_.resize(n + m, 3 * points);
  woodbury_w_.resize(3 * points, 3 * points);
  woodbury_y_.setZero();
  for (int k = 0; k < points; ++k) {
    for (int j = 0; j < 3; ++j)
      woodbury_y_(n + system_.interface_points[static_cast<size_t>(k)].first_row + j, 3 * k + j) = 1.0;
  }
  lu_.SolveInPlace(woodbury_y_);  // all columns in one pass over the factors
  for (int k = 0; k < points; ++k) {
    woodbury_w_.middleRows(3 * k, 3) =
        woodbury_y_.middleRows(n + system_.interface_points[static_cast<size_t>(k)].first_row, 3);
  }
}

void CgAlpha::AddComplianceCorrection(Eigen::Ref<Eigen::VectorXd> x, const Eigen::Matrix3d& to_factorized) {
  // (J − P Ĉ Pᵀ)⁻¹ r = z + Y Ĉ (I − W Ĉ)⁻¹ Pᵀ z with z = J⁻¹ r, Ĉ = C/(βh²) the peers'
  // compliance per point (Woodbury's identity in the form that allows a singular Ĉ: a node
  // resting on its plane has no normal compliance). Co-rotated (x already turned into the
  // factorised axes, J = T J₀ Tᵀ): TᵀP = P Rᵀ on the interface triples, so the compliance is
  // taken into those axes as well, Ĉ₀ = Rᵀ Ĉ R (to_factorized = Rᵀ).
  const std::vector<Eigen::Matrix3d>& compliance = data_->interface_compliance;
  bool any = false;
  for (const Eigen::Matrix3d& c : compliance) any = any || !c.isZero(0.0);
  if (!any) return;
  const int n = system_.coordinates, points = static_cast<int>(compliance.size());
  const double bh2 = coef_.beta * h_factorized_ * h_factorized_;
  woodbury_c_.setZero(3 * points, 3 * points);
  woodbury_g_.resize(3 * points);
  for (int k = 0; k < points; ++k) {
    woodbury_c_.block<3, 3>(3 * k, 3 * k) =
        to_factorized * compliance[static_cast<size_t>(k)] * to_factorized.transpose() / bh2;
    woodbury_g_.segment<3>(3 * k) = x.segment<3>(n + system_.interface_points[static_cast<size_t>(k)].first_row);
  }
  const Eigen::MatrixXd M = Eigen::MatrixXd::Identity(3 * points, 3 * points) - woodbury_w_ * woodbury_c_;
  const Eigen::VectorXd u = woodbury_c_ * M.partialPivLu().solve(woodbury_g_);
  x.noalias() += woodbury_y_ * u;
}

Eigen::Matrix3d CgAlpha::InterfaceResponse(int k, double h) {
  // A change δx of the imposed position changes the rows' residual by −δx, so the Newton
  // correction is J⁻¹ [0; δx e_rows] and λ moves by its multiplier part / βh² — with J the
  // smooth model's own matrix (the peers' compliance not in it).
  const double bh2 = coef_.beta * h * h;
  // Co-rotated reuse: Pₖᵀ T J₀⁻¹ Tᵀ Pₖ = R Wₖ Rᵀ with R from the factorised axes to the state's.
  const Eigen::Matrix3d R = TurnSinceFactorized(state_.q);
  return R * woodbury_w_.block<3, 3>(3 * k, 3 * k) * R.transpose() / bh2;
}

void CgAlpha::ConstraintRows(double t1, bool phi_known) {
  // rows_ = Φ − cλ (position rows) or Φ_q q̇ + Φ_t (velocity rows) at next_; phi_ = Φ, taken
  // as it is when the projection has just evaluated it at next_.q.
  const ConstraintSet& cs = system_.constraints;
  const ImposedValues& imposed = data_->imposed;
  if (!phi_known) cs.Evaluate(imposed, next_.q, t1, phi_);
  rows_ = phi_;
  if (any_velocity_row_) {
    cs.JacobianTimes(imposed, next_.q, t1, next_.qdot, rate_, &velocity_row_);
    cs.TimeDerivative(imposed, next_.q, t1, phi_t_, &velocity_row_);
    for (Eigen::Index i = 0; i < rows_.size(); ++i) {
      if (velocity_row_[static_cast<size_t>(i)] != 0) rows_(i) = rate_(i) + phi_t_(i);
    }
  }
  for (size_t i = 0; i < cs.compliance.size(); ++i) {
    rows_(static_cast<Eigen::Index>(i)) -= cs.compliance[i] * next_.lambda(static_cast<Eigen::Index>(i));
  }
  const std::vector<Eigen::Matrix3d>& compliance = data_->interface_compliance;
  for (size_t k = 0; k < compliance.size(); ++k) {
    if (compliance[k].isZero(0.0)) continue;
    const int row = system_.interface_points[k].first_row;
    rows_.segment<3>(row) -= compliance[k] * next_.lambda.segment<3>(row);
  }
}

double CgAlpha::ScaledRows(double velocity_scale, Eigen::Ref<Eigen::VectorXd> out) const {
  out = rows_;
  if (any_velocity_row_) {
    for (Eigen::Index i = 0; i < out.size(); ++i) {
      if (velocity_row_[static_cast<size_t>(i)] != 0) out(i) *= velocity_scale;
    }
  }
  return out.size() > 0 ? out.lpNorm<Eigen::Infinity>() : 0.0;
}

void CgAlpha::OrthonormaliseBeamNodes() {
  for (int b : beam_nodes_) {
    const int o = kCoordinatesPerBody * b + 3;
    Eigen::Matrix3d A;
    for (int k = 0; k < 3; ++k) A.col(k) = next_.q.segment<3>(o + 3 * k);
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(A, Eigen::ComputeFullU | Eigen::ComputeFullV);
    const Eigen::Matrix3d R = svd.matrixU() * svd.matrixV().transpose();
    for (int k = 0; k < 3; ++k) next_.q.segment<3>(o + 3 * k) = R.col(k);
  }
}

bool CgAlpha::ProjectPositions(double t1, StepStatus* status) {
  // Chord iteration on Φ(q) = 0 (velocity rows only; the position rows hold already) with the
  // last Newton factorisation: its constraint rows are Φ_q + O(h) (Φ_q q̇)_q, so each solve
  // cuts the violation by a factor O(Ωh); the violation left by one step is O(h³). Leaves
  // phi_ = Φ at the projected positions.
  const int n = system_.coordinates, m = system_.constraints.size();
  auto rhs = delta_.tail(m);
  // Held well below the Newton tolerance (the index-3 Newton's quadratic convergence usually
  // leaves |Φ| far below it too), down to round-off: a solve that no longer halves the
  // violation has reached it.
  const double target = std::max(1e-4 * settings_.tolerance, 1e-14);
  double previous = std::numeric_limits<double>::infinity();
  for (int k = 0;; ++k) {
    // A beam node's rigidity rows closed exactly, in the Euclidean metric of its axes (the
    // direction of GGL's Φ_qᵀν): the chord solves' matrix leans from Φ_q by |ω| βh/γ, and a
    // section's rotation rates against the beam's shear and bending stiffness (ωh of 10²–10³)
    // made that lean large enough for the chord iteration to stall, then diverge (generated
    // rotor 707, blades of 5 quadratic elements at 116 rad/s: |Φ| = inf within 0.08 s in both
    // stop models). The chord solves below then close the other velocity rows.
    OrthonormaliseBeamNodes();
    system_.constraints.Evaluate(data_->imposed, next_.q, t1, phi_);
    for (int i = 0; i < m; ++i) {
      const size_t r = static_cast<size_t>(i);
      rhs(i) = velocity_row_[r] != 0 && beam_node_row_[r] == 0 ? -phi_(i) : 0.0;
    }
    const double violation = rhs.lpNorm<Eigen::Infinity>();
    if (violation <= target || (violation > 0.5 * previous && violation <= settings_.tolerance)) return true;
    // A slow but steady contraction (the velocity rows of the matrix lean by |ω| βh/γ from Φ_q,
    // and a beam's section rotations can spin fast in its stiff modes) is accepted once within
    // the Newton tolerance after 10 solves.
    if (k >= 10 && violation <= settings_.tolerance) return true;
    if (k == 30 || !std::isfinite(violation)) {
      status->outcome = StepStatus::Outcome::kProjectionFailed;
      status->violation = violation;
      status->solves = k;
      return false;
    }
    previous = violation;
    delta_.head(n).setZero();
    Solve(delta_);
    next_.q += delta_.head(n);
    ++projection_solves_;
  }
}

std::string StepStatus::Describe(const CgAlphaSettings& settings) const {
  const std::string at = "at t = " + interface::FormatNumber(time) + " s";
  switch (outcome) {
    case Outcome::kConverged:
      return "CGα: converged " + at + " in " + std::to_string(iterations) + " iterations";
    case Outcome::kNotConverged:
    case Outcome::kNonFiniteCorrection:
      return "CGα: Newton did not converge in " + std::to_string(settings.max_iterations) + " iterations " + at +
             " (tolerance " + interface::FormatNumber(settings.tolerance) +
             "); reduce the step or raise numerics.smooth.newton_max_iterations";
    case Outcome::kDiverged:
      return "CGα: Newton diverged " + at + " (iteration " + std::to_string(failed_iteration) +
             ": the iteration matrix is no longer finite)";
    case Outcome::kProjectionFailed:
      return "CGα: the position projection did not converge " + at + " (|Φ| = " + interface::FormatNumber(violation) +
             " after " + std::to_string(solves) + " solves); reduce the step";
    case Outcome::kNonFiniteSolution:
      return "CGα: Newton reached non-finite multipliers or rates " + at;
    case Outcome::kSingularMatrix:
      return "CGα: the iteration matrix is singular at t = " + std::to_string(time) +
             " s (redundant constraints or a singular configuration)";
  }
  return "CGα: unknown outcome";
}

std::string StepStatus::AfterRetries(std::string why, int pieces, double h, double t) {
  const auto replace = [&why](const std::string& from, const std::string& to) {
    const size_t at = why.find(from);
    if (at != std::string::npos) why.replace(at, from.size(), to);
  };
  replace("; reduce the step or raise", "; raise");
  replace("; reduce the step", "");
  return why + " (retried as " + std::to_string(pieces) + " steps of " + interface::FormatNumber(h) +
         " s from t = " + interface::FormatNumber(t) + " s: the smaller steps failed too)";
}

int CgAlpha::Step(double t, double h, const DaeState* guess) {
  const StepStatus status = TryStep(t, h, guess);
  if (!status.ok()) throw NumericalError(status.Describe(settings_));
  return status.iterations;
}

StepStatus CgAlpha::TryStep(double t, double h, const DaeState* guess, const InterfaceMotion* motion) {
  if (motion != nullptr) data_->TakeMotion(*motion);
  const int m = system_.constraints.size();
  const double t1 = t + h;
  StepStatus status;
  status.time = t1;
  if (RestartAtRelease(system_, *data_, t, t1, &state_)) {
    a_ = state_.qddot;
    elastic_.Reset(state_.q);
    started_ = true;
  }
  // A failed step leaves the integrator as it was, its start-up too: the retry starts up again
  // (a start-up that failed used to mark the integrator started, and the retried first step
  // then went without it).
  const bool starting = !started_;
  if (starting) {
    // a_0 = q̈(t_0 + Δα h), Δα = αm − αf < 0 (accurate to O(h²), which is what second order
    // needs): the accelerations consistent with the state at t_0 + Δα h, and that state from
    // one trapezoidal step (CGα with ρ∞ = 1, time-reversible) of length Δα h.
    // A Taylor-shifted state q + δ q̇ + ½ δ² q̈ would do for smooth motion, but a velocity field
    // with stiff components (ωh ≫ 1, e.g. an elastic body's through-thickness modes) turns
    // into an acceleration ~ ω²|δ| |q̇|, far above the true ~ω |q̇|, and the first steps then
    // pump energy into those modes (observed: a beam's energy ×12 in ten steps with ρ∞ = 0.6);
    // the trapezoidal step keeps every mode's amplitude (|amplification| = 1). Its own end
    // accelerations are not used: for curved constraints the index-3 trapezoidal rule gives
    // Φ_q q̈ the wrong sign (Φ_q (q̈_0 + q̈_1) = O(δ) instead of 2 Φ_q q̈), hence the
    // consistent accelerations at its end state.
    started_ = true;
    const double delta = (coef_.alpha_m - coef_.alpha_f) * h;
    if (delta != 0.0) {
      CgAlphaSettings trapezoidal = settings_;
      trapezoidal.rho_inf = 1.0;  // Δα = 0: no start-up of its own
      CgAlpha shift(system_, data_, trapezoidal, state_);
      const StepStatus shifted_status = shift.TryStep(t, delta);
      if (!shifted_status.ok()) {
        started_ = false;
        return shifted_status;
      }
      DaeState shifted = shift.state();
      ConsistentAccelerations(system_, *data_, t + delta, &shifted);
      a_ = shifted.qddot;
    }
  }
  // Predictor: q̈_{n+1} = q̈_n, λ_{n+1} = λ_n; a, q, q̇ from Eqs. (3) and (5).
  next_.qddot = state_.qddot;
  next_.lambda = state_.lambda;
  for (int i = 0; i < m; ++i) {
    if (!system_.constraints.Active(static_cast<size_t>(i), t1)) next_.lambda(i) = 0.0;  // released joint
  }
  a_next_ = (state_.qddot - coef_.alpha_m * a_) / (1.0 - coef_.alpha_m);
  next_.q = state_.q + h * state_.qdot + h * h * ((0.5 - coef_.beta) * a_ + coef_.beta * a_next_);
  next_.qdot = state_.qdot + h * ((1.0 - coef_.gamma) * a_ + coef_.gamma * a_next_);
  if (guess != nullptr && starting) {
    // A start-up step's a_0 depends on the imposed coordinates, so a guess solved in an earlier
    // try of this step (other coordinates) came from another predictor: it gives the positions
    // and multipliers to start from, and the velocities and accelerations follow from them through
    // this try's Newmark relations (q̇ − q̇* = γ/(βh) (q − q*), q̈ − q̈_n = β' (q − q*), which
    // Newton's corrections keep). Taken whole, Newton converged to positions whose velocities
    // belonged to the other predictor: the step's root depended on its starting point (a rod
    // settled on a stiff tie: 5.27 N in it instead of 4.905 N; InterfacePoint tests).
    const double beta_prime = (1.0 - coef_.alpha_m) / ((1.0 - coef_.alpha_f) * coef_.beta * h * h);
    const double gamma_prime = coef_.gamma / (coef_.beta * h);
    auto shift = delta_.head(system_.coordinates);  // (scratch: Newton overwrites it)
    shift = guess->q - next_.q;
    next_.q = guess->q;  // assignments of equal sizes: no allocation
    next_.qdot += gamma_prime * shift;
    next_.qddot += beta_prime * shift;
    next_.lambda = guess->lambda;
  } else if (guess != nullptr) {
    // Any other step's tries share one predictor: the guess is taken whole (a projected solve's
    // positions are off its Newmark relations by the projection, which the guess keeps).
    next_ = *guess;  // assignments of equal sizes: no allocation
  }

  const bool reuse = factorized_ && settings_.jacobian_max_age > 0 && SameStepLength(h, h_factorized_) &&
                     age_ < settings_.jacobian_max_age;
  // Co-rotated reuse (frame_body set) also keeps a step's first fresh matrix for its later
  // iterations; plain reuse keeps full Newton in a step that starts with a fresh matrix.
  const Matrices matrices = reuse                       ? Matrices::kReused
                            : settings_.frame_body >= 0 ? Matrices::kFreshFirst
                                                        : Matrices::kFreshEach;
  if (matrices != Matrices::kFreshEach) predicted_ = next_;  // kept for a retry with fresh matrices
  Newton(t1, h, matrices, &status);
  if (!status.ok() && status.outcome != StepStatus::Outcome::kSingularMatrix && matrices != Matrices::kFreshEach) {
    next_ = predicted_;
    Newton(t1, h, Matrices::kFreshEach, &status);
  }
  if (status.ok()) {
    // Accept: a_{n+1} from Eq. (3).
    a_ = ((1.0 - coef_.alpha_f) * next_.qddot + coef_.alpha_f * state_.qddot - coef_.alpha_m * a_) /
         (1.0 - coef_.alpha_m);
    elastic_.Accept(state_.q, next_.q);
    std::swap(state_, next_);
    ++age_;
  } else if (starting) {
    started_ = false;  // (a_ is set again by the next start-up)
  }
  return status;
}

Eigen::Matrix3d CgAlpha::FrameAxes(const Eigen::VectorXd& q) const { return BodyAxes(q, settings_.frame_body); }

Eigen::Matrix3d CgAlpha::TurnSinceFactorized(const Eigen::VectorXd& q) const {
  if (settings_.frame_body < 0) return Eigen::Matrix3d::Identity();
  return FrameAxes(q) * factorized_axes_.transpose();
}

void CgAlpha::Solve(Eigen::Ref<Eigen::VectorXd> x) { SolveAt(x, next_.q); }

void CgAlpha::SolveAt(Eigen::Ref<Eigen::VectorXd> x, const Eigen::VectorXd& q) {
  if (settings_.frame_body < 0) {
    lu_.SolveInPlace(x);
    if (woodbury_) AddComplianceCorrection(x, Eigen::Matrix3d::Identity());
    return;
  }
  // x = T S₀⁻¹ Tᵀ x with T = R on every coordinate triple and multiplier triple, R = F F₀ᵀ.
  const Eigen::Matrix3d R = TurnSinceFactorized(q);
  const int n = system_.coordinates;
  auto rotate = [&](const Eigen::Matrix3d& r) {
    for (int k = 0; k < n; k += 3) x.segment<3>(k) = r * x.segment<3>(k);
    for (int row : system_.constraints.vector_triples) x.segment<3>(n + row) = r * x.segment<3>(n + row);
  };
  rotate(R.transpose());
  lu_.SolveInPlace(x);
  if (woodbury_) AddComplianceCorrection(x, R.transpose());
  rotate(R);
}

void CgAlpha::Newton(double t1, double h, Matrices matrices, StepStatus* status) {
  const int n = system_.coordinates, m = system_.constraints.size();
  const double bh2 = coef_.beta * h * h;
  const double beta_prime = (1.0 - coef_.alpha_m) / ((1.0 - coef_.alpha_f) * bh2);
  const double gamma_prime = coef_.gamma / (coef_.beta * h);
  double previous_dq = std::numeric_limits<double>::infinity();
  using Outcome = StepStatus::Outcome;
  ConstraintRows(t1, /*phi_known=*/false);
  for (int iteration = 1; iteration <= settings_.max_iterations; ++iteration) {
    ++status->iterations;
    // Residual, scaled: [βh² (M q̈ + f̃ − f + Φ_qᵀ λ); Φ], and the matrix unless reused.
    system_.Force(next_.q, next_.qdot, t1, *data_, force_, /*include_elastic=*/false);
    const bool fresh = matrices == Matrices::kFreshEach || (matrices == Matrices::kFreshFirst && iteration == 1);
    if (fresh) {
      AssembleIteration(t1, h);  // also force_ −= f̃_{n+1}
    } else {
      elastic_.Add(state_.q, next_.q, force_, bh2, nullptr);  // force_ −= f̃_{n+1}
    }
    auto r_q = residual_.head(n);
    r_q.noalias() = system_.mass * next_.qddot;
    r_q -= force_;
    system_.constraints.AddJacobianTransposeTimes(data_->imposed, next_.q, t1, next_.lambda, r_q);
    r_q *= bh2;
    ScaledRows(1.0 / gamma_prime, residual_.tail(m));  // rows_ is at next_ (below, or before the loop)
    if (fresh) {
      ++factorizations_;
      factorized_ = false;
      if (settings_.frame_body >= 0) factorized_axes_ = FrameAxes(next_.q);
      // A diverging iteration overflows the matrix before its corrections stop being finite
      // (observed: |q| 3e158 after 13 iterations): a failed Newton solve, not a singular model.
      const Eigen::Map<const Eigen::VectorXd> values(S_.valuePtr(), S_.nonZeros());
      if (!values.allFinite()) {
        status->outcome = Outcome::kDiverged;
        status->failed_iteration = iteration;
        return;
      }
      if (!lu_.Factorize(S_)) {
        status->outcome = Outcome::kSingularMatrix;
        return;
      }
      factorized_ = true;
      h_factorized_ = h;
      age_ = 0;
      if (woodbury_) FactorizeInterfaceColumns();
    }
    delta_ = -residual_;
    Solve(delta_);
    const auto dq = delta_.head(n);
    next_.q += dq;
    next_.qdot += gamma_prime * dq;
    next_.qddot += beta_prime * dq;
    next_.lambda += delta_.tail(m) / bh2;
    const double dq_norm = dq.lpNorm<Eigen::Infinity>();
    if (!std::isfinite(dq_norm)) {
      status->outcome = Outcome::kNonFiniteCorrection;
      return;
    }
    // INDEX2_PROJECTED: the positions back onto Φ = 0 (velocity rows) inside the iteration, as a
    // displacement of q alone (q̇ and q̈ stay the Newmark ones): the next residual, forces and
    // the GEMM elastic force then see the corrected positions, as in the coupled GGL form
    // q_{n+1} = q_Newmark + Φ_qᵀν. Projecting only after convergence leaves λ and f̃ at the
    // uncorrected positions, and the multipliers drop to first order (observed: 1.0–1.2 for the
    // flexible pendulum's reactions, 2.1 with the projection here).
    if (any_velocity_row_ && !ProjectPositions(t1, status)) return;
    // Converged: small correction and the closing rows met (velocity rows measured as h |Φ_q q̇ + Φ_t|,
    // the position change their violation makes over one step). rows_ serves the next iteration too.
    ConstraintRows(t1, /*phi_known=*/any_velocity_row_);
    const double phi_norm = ScaledRows(h, violation_step_);
    const double dq_tolerance = settings_.tolerance * (1.0 + next_.q.lpNorm<Eigen::Infinity>());
    // With a matrix from an earlier iteration the convergence is linear, and the error left
    // behind is about ρ/(1 − ρ) |Δq| (ρ: the contraction of the last two corrections, taken as
    // reuse_contraction when there is only one) instead of full Newton's O(|Δq|²): such an
    // iterate is accepted only once that estimate is below kReusedErrorShare of the tolerance,
    // about what full Newton's last iteration leaves (docs/design.md, "Co-rotated reuse").
    // (Co-rotated reuse only so far: with the projected form, the extra iterations move the
    // positions along the stale matrix's projection directions, docs/design.md "Newton-matrix
    // reuse", and the four-bar of JacobianReuse ends 3e-6 away instead of 5e-8.)
    bool accurate = true;
    if (!fresh && settings_.frame_body >= 0) {
      const double rho =
          std::min(std::isfinite(previous_dq) ? dq_norm / previous_dq : settings_.reuse_contraction, 0.9);
      accurate = rho / (1.0 - rho) * dq_norm <= kReusedErrorShare * dq_tolerance;
    }
    if (dq_norm <= dq_tolerance && accurate && phi_norm <= settings_.tolerance) {
      // Only a finite iterate is a solution: the multipliers are not in the test above, and a
      // reused matrix far from today's can leave them non-finite with a small |Δq| (observed:
      // the continuous Puma engagement at h = 2 ms, jacobian_max_age 80, the watchdog at 26.4 s).
      status->outcome = next_.lambda.allFinite() && next_.qdot.allFinite() && next_.qddot.allFinite()
                            ? Outcome::kConverged
                            : Outcome::kNonFiniteSolution;
      return;
    }
    // A reused matrix that no longer contracts the correction well is replaced by a fresh one
    // for the rest of the step (full Newton from here).
    if (matrices != Matrices::kFreshEach && dq_norm > settings_.reuse_contraction * previous_dq) {
      matrices = Matrices::kFreshEach;
    }
    previous_dq = dq_norm;
  }
  status->outcome = Outcome::kNotConverged;
}

}  // namespace cosim::smooth
