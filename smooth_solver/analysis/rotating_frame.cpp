#include "smooth_solver/analysis/rotating_frame.h"

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <Eigen/SparseLU>
#include <algorithm>
#include <cmath>

#include "interface/scenario/checks.h"
#include "smooth_solver/linear_algebra/fixed_pattern_matrix.h"

namespace cosim::smooth {

namespace {

// Adds into a dense matrix (analysis only).
class DenseSink : public SparseSink {
 public:
  explicit DenseSink(Eigen::MatrixXd* m, int row = 0, int col = 0) : m_(m), row_(row), col_(col) {}
  void Add(int r, int c, double v) override { (*m_)(r + row_, c + col_) += v; }

 private:
  Eigen::MatrixXd* m_;
  int row_, col_;
};

class TripletSink : public SparseSink {
 public:
  void Add(int r, int c, double v) override { t_.emplace_back(r, c, v); }
  Eigen::SparseMatrix<double> Build(int n) const {
    Eigen::SparseMatrix<double> m(n, n);
    m.setFromTriplets(t_.begin(), t_.end());
    m.makeCompressed();
    return m;
  }

 private:
  std::vector<Eigen::Triplet<double>> t_;
};

// Which coordinate triples are points (the rest are directions): each body's first triple and
// every elastic-body node.
std::vector<char> PointTriples(const MultibodySystem& system) {
  const int triples = system.coordinates / 3;
  const int rigid = system.rigid_coordinates();
  std::vector<char> point(static_cast<size_t>(triples), 1);
  for (int k = 0; k < rigid / 3; ++k) point[static_cast<size_t>(k)] = (k % 4 == 0) ? 1 : 0;
  return point;
}

Eigen::Matrix3d Skew(const Eigen::Vector3d& w) {
  Eigen::Matrix3d S;
  S << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  return S;
}

// Block-diagonal I ⊗ A over all triples (sparse).
Eigen::SparseMatrix<double> PerTriple(int n, const Eigen::Matrix3d& A) {
  std::vector<Eigen::Triplet<double>> t;
  for (int k = 0; k < n / 3; ++k) {
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        if (A(i, j) != 0.0) t.emplace_back(3 * k + i, 3 * k + j, A(i, j));
      }
    }
  }
  Eigen::SparseMatrix<double> m(n, n);
  m.setFromTriplets(t.begin(), t.end());
  return m;
}

Eigen::VectorXd WithoutOrigin(const MultibodySystem& system, const Eigen::VectorXd& q, const Eigen::Vector3d& origin) {
  const std::vector<char> point = PointTriples(system);
  Eigen::VectorXd qh = q;
  for (size_t k = 0; k < point.size(); ++k) {
    if (point[k]) qh.segment<3>(3 * static_cast<Eigen::Index>(k)) -= origin;
  }
  return qh;
}

// The Newton matrix of the static residual at (q, λ) in the spinning frame: −∂f/∂q with the
// air's share at the frame's velocities W q̂, M W², the constraints' Hessian, Jacobian and
// compliance (StaticEquilibrium's residual, below).
void StaticTangent(const MultibodySystem& system, const SystemData& data, const Eigen::VectorXd& q,
                   const Eigen::VectorXd& lambda, const SpinningFrame& frame, double t,
                   const Eigen::SparseMatrix<double>& MW2, TripletSink* sink) {
  const int n = system.coordinates;
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
  system.AddForceTangent(q, zero, t, data, 1.0, 0.0, sink);
  if (system.air_loads != nullptr) {
    const Eigen::VectorXd v = SpinningVelocity(system, q, frame);
    TripletSink damping;
    system.air_loads->AddTangent(q, v, t, data, 1.0, 0.0, sink);
    system.air_loads->AddTangent(q, zero, t, data, -1.0, 0.0, sink);
    system.air_loads->AddTangent(q, v, t, data, 0.0, 1.0, &damping);
    const Eigen::SparseMatrix<double> W = PerTriple(n, Skew(frame.omega));
    AddSparse(Eigen::SparseMatrix<double>(damping.Build(n) * W), 1.0, sink);  // −∂f/∂q̇ · ∂(W q̂)/∂q
  }
  AddSparse(MW2, 1.0, sink);
  system.constraints.HessianTimesLambda(data.imposed, t, lambda, sink, 1.0);
  system.constraints.JacobianTranspose(data.imposed, q, t, sink, n, 1.0);
  system.constraints.Jacobian(data.imposed, q, t, sink, n, 1.0);
  system.constraints.AddReleasedDiagonal(t, sink, n);
  system.constraints.AddComplianceDiagonal(sink, n, 1.0);
}

// The sliding nodes' unknowns s (EquilibriumOptions::sliding), after q and λ from `first` on:
// node k at x_k = base_k + T_k s_k, the imposed value of its tie's rows Φ = p(q) − x − cλ
// (∂Φ/∂s = −T_k), with its balance along T_k as rows of their own.
//
// A proximal spring on each, kSlideStiffness (s − s_anchor): a node may slide along a direction
// nothing else stiffens, with the body it is tied to (a rigid blade's free lag hinge at rest:
// blade and pad turn together, a singular matrix without it; observed on generated rotor 312).
// Each time Newton converges, the anchor moves to the solution, until the spring's force is below
// 1e-4 of the node's load and reactions (+ 1e-7 N): a node on a stiff tie (1/c ~ 1e8 N/m) needs
// one more solve; along a neutral direction it moves by the stray force over kSlideStiffness and
// stays where that force is within the tolerance (an equilibrium where the rest check,
// node_rest.h, holds), or drifts until max_iterations where a real force pushes it along (no
// equilibrium).
class SlidingUnknowns {
 public:
  static constexpr double kSlideStiffness = 1.0;  // [N/m]

  SlidingUnknowns(const MultibodySystem& system, const std::vector<SlidingNode>& nodes, int first)
      : system_(system), nodes_(nodes) {
    for (const SlidingNode& node : nodes) {
      at_.push_back(size_);
      size_ += static_cast<int>(node.directions.cols());
    }
    first_ = first;
    anchor_ = Eigen::VectorXd::Zero(size_);
  }
  int size() const { return size_; }
  Eigen::Vector3d Position(size_t k, const Eigen::VectorXd& s) const {
    return nodes_[k].base + nodes_[k].directions * s.segment(at_[k], nodes_[k].directions.cols());
  }
  // The tie rows' imposed values at s.
  void Place(const Eigen::VectorXd& s, SystemData* data) const {
    for (size_t k = 0; k < nodes_.size(); ++k) {
      const Eigen::Vector3d x = Position(k, s);
      for (size_t j = 0; j < 3; ++j)
        data->imposed[3 * static_cast<size_t>(nodes_[k].point) + j].value = x(static_cast<Eigen::Index>(j));
    }
  }
  // Each node's balance along its directions, Tᵀ(λ_k + load(x)), and its proximal spring.
  void Residual(const Eigen::VectorXd& lambda, const Eigen::VectorXd& s, Eigen::Ref<Eigen::VectorXd> out) const {
    for (size_t k = 0; k < nodes_.size(); ++k) {
      const SlidingNode& node = nodes_[k];
      const Eigen::Vector3d force =
          system_.InterfaceReaction(node.point, lambda) + node.load + node.stiffness * (Position(k, s) - node.base);
      const Eigen::Index d = node.directions.cols();
      out.segment(at_[k], d) =
          node.directions.transpose() * force + kSlideStiffness * (s.segment(at_[k], d) - anchor_.segment(at_[k], d));
    }
  }
  // Their rows and columns of the Newton matrix (`n` coordinates before the constraint rows).
  void Tangent(int n, SparseSink* sink) const {
    for (size_t k = 0; k < nodes_.size(); ++k) {
      const SlidingNode& node = nodes_[k];
      const int tie = n + system_.interface_points[static_cast<size_t>(node.point)].first_row;
      const Eigen::MatrixXd& T = node.directions;
      const Eigen::MatrixXd TKT = T.transpose() * node.stiffness * T;
      for (Eigen::Index i = 0; i < T.cols(); ++i) {
        const int row = first_ + at_[k] + static_cast<int>(i);
        for (int j = 0; j < 3; ++j) {
          sink->Add(tie + j, row, -T(j, i));  // ∂Φ/∂s
          sink->Add(row, tie + j, T(j, i));   // ∂(Tᵀλ_k)/∂λ
        }
        for (Eigen::Index l = 0; l < T.cols(); ++l) sink->Add(row, first_ + at_[k] + static_cast<int>(l), TKT(i, l));
        sink->Add(row, row, kSlideStiffness);
      }
    }
  }
  // The share of the step ds that takes every node at most onto the first guard plane in its
  // way (1: none), and which node and guard that is (left as they were if none).
  double GuardFraction(const Eigen::VectorXd& s, const Eigen::VectorXd& ds, int* node, int* guard) const {
    double fraction = 1.0;
    for (size_t k = 0; k < nodes_.size(); ++k) {
      const Eigen::Vector3d from = Position(k, s), to = Position(k, s + ds);
      for (size_t g = 0; g < nodes_[k].guards.size(); ++g) {
        const auto& [point, normal] = nodes_[k].guards[g];
        const double before = std::max(normal.dot(from - point), 0.0), after = normal.dot(to - point);
        if (after >= 0.0 || before / (before - after) >= fraction) continue;
        fraction = before / (before - after);
        *node = static_cast<int>(k);
        *guard = static_cast<int>(g);
      }
    }
    return fraction;
  }
  // Whether every proximal spring's force is within its tolerance.
  bool Anchored(const Eigen::VectorXd& lambda, const Eigen::VectorXd& s) const {
    for (size_t k = 0; k < nodes_.size(); ++k) {
      const Eigen::Index d = nodes_[k].directions.cols();
      const double load = (system_.InterfaceReaction(nodes_[k].point, lambda) + nodes_[k].load).norm();
      if (kSlideStiffness * (s.segment(at_[k], d) - anchor_.segment(at_[k], d)).norm() > 1e-4 * load + 1e-7)
        return false;
    }
    return true;
  }
  void Anchor(const Eigen::VectorXd& s) { anchor_ = s; }

 private:
  const MultibodySystem& system_;
  const std::vector<SlidingNode>& nodes_;
  std::vector<int> at_;  // node k's first entry in s
  int size_ = 0, first_ = 0;
  Eigen::VectorXd anchor_;
};

constexpr double kPseudoMass = 1.0;  // μ [1/s²]: 0.16 Hz, below any structural mode

// One step δ of the static solve, (K + μM) δ = −R (StaticEquilibrium says when μ > 0), over the
// coordinates (the first n entries), the multipliers and the sliding unknowns (the last ones).
class NewtonStep {
 public:
  NewtonStep(const Eigen::SparseMatrix<double>& K, const Eigen::SparseMatrix<double>& mass, const Eigen::VectorXd& R,
             int n, int sliding)
      : K_(K), mass_(mass), R_(R), n_(n), sliding_(sliding) {}
  // The longest move in q and s, |δ|∞.
  double Moves() const {
    return std::max(delta_.head(n_).lpNorm<Eigen::Infinity>(), delta_.tail(sliding_).lpNorm<Eigen::Infinity>());
  }
  // Solves with μ = *pseudo_mass, raising it in pseudo-time; false if the matrix is singular.
  bool Solve(const EquilibriumOptions& options, double* pseudo_mass) {
    bool solved = Factor(*pseudo_mass);
    if (!solved && *pseudo_mass == 0.0) {
      // A mechanism at the guess: a coordinate that nothing stiff holds there, as a blade drawn
      // exactly on a Hunt–Crossley stop, whose tangent k n δ^(n−1) vanishes at δ = 0 (generated
      // articulated rotors' continuous twins, settled on their droop stops: LU failed before the
      // first iteration). That step is taken in pseudo-time: the load moves the free coordinate
      // into the contact, whose tangent then holds it; later iterations are plain Newton again.
      solved = Factor(kPseudoMass);
    }
    // In pseudo-time, μ raised (×4, or more for a long step) until the step is within max_step
    // and goes where the loads push: their work along it, −R·δ over q and s (= δᵀ(K + μM)δ near
    // the constraint manifold), positive. Not judged on steps within the tolerance's square root.
    for (int tries = 0; solved && *pseudo_mass > 0.0 && tries < 12; ++tries) {
      if (Moves() <= options.max_step && !Uphill(options.tolerance)) break;
      *pseudo_mass *= 4.0 * std::max(1.0, Moves() / options.max_step);
      solved = Factor(*pseudo_mass);
    }
    return solved;
  }
  Eigen::VectorXd& delta() { return delta_; }

 private:
  bool Factor(double mu) {
    lu_.compute(mu > 0.0 ? Eigen::SparseMatrix<double>(K_ + mu * mass_) : K_);
    if (lu_.info() != Eigen::Success) return false;
    delta_ = lu_.solve(-R_);
    return true;
  }
  bool Uphill(double tolerance) const {
    const double work = -(R_.head(n_).dot(delta_.head(n_)) + R_.tail(sliding_).dot(delta_.tail(sliding_)));
    return work < 0.0 && Moves() > std::sqrt(tolerance);
  }
  const Eigen::SparseMatrix<double>& K_;
  const Eigen::SparseMatrix<double>& mass_;
  const Eigen::VectorXd& R_;
  int n_, sliding_;
  Eigen::SparseLU<Eigen::SparseMatrix<double>> lu_;
  Eigen::VectorXd delta_;
};

}  // namespace

Eigen::VectorXd SpinningVelocity(const MultibodySystem& system, const Eigen::VectorXd& q, const SpinningFrame& frame) {
  // W q̂ triple by triple (no sparse W built: the static solve calls this every iteration).
  const Eigen::VectorXd qh = WithoutOrigin(system, q, frame.origin);
  Eigen::VectorXd v(q.size());
  for (Eigen::Index k = 0; k + 2 < q.size(); k += 3)
    v.segment<3>(k) = frame.omega.cross(Eigen::Vector3d(qh.segment<3>(k)));
  return v;
}

EquilibriumResult StaticEquilibrium(const MultibodySystem& system, SystemData* data, const Eigen::VectorXd& q_guess,
                                    const SpinningFrame& frame, const EquilibriumOptions& options) {
  const int n = system.coordinates, m = system.constraints.size();
  SlidingUnknowns sliding(system, options.sliding, n + m);
  const int N = n + m + sliding.size();
  Eigen::VectorXd s = Eigen::VectorXd::Zero(sliding.size());
  const Eigen::SparseMatrix<double> MW2 = system.mass * PerTriple(n, Skew(frame.omega) * Skew(frame.omega));
  EquilibriumResult r;
  r.q = q_guess;
  r.lambda = Eigen::VectorXd::Zero(m);
  // At rest in the spinning frame every triple moves with Ω × (its point off the axis, or its
  // direction): the absolute velocities W q̂ that the air loads see. The other elements are
  // objective (dampers, Kelvin–Voigt: no force for a rigid rotation) and are taken at q̇ = 0,
  // where their tangents are exact (some leave out ∂C/∂q q̇).
  auto velocity = [&](const Eigen::VectorXd& q) -> Eigen::VectorXd { return SpinningVelocity(system, q, frame); };
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
  const AirLoads* air = system.air_loads;
  auto residual = [&](const Eigen::VectorXd& q, const Eigen::VectorXd& lambda, Eigen::VectorXd* R) {
    R->resize(N);
    sliding.Place(s, data);
    Eigen::VectorXd f(n);
    system.Force(q, zero, options.t, *data, f);
    if (air != nullptr) {  // the air's share at W q̂ instead of at rest
      Eigen::VectorXd moving = Eigen::VectorXd::Zero(n), still = Eigen::VectorXd::Zero(n);
      air->AddForce(q, velocity(q), options.t, *data, moving);
      air->AddForce(q, zero, options.t, *data, still);
      f += moving - still;
    }
    R->head(n) = -f + MW2 * WithoutOrigin(system, q, frame.origin);
    system.constraints.AddJacobianTransposeTimes(data->imposed, q, options.t, lambda, R->head(n));
    system.constraints.Evaluate(data->imposed, q, options.t, R->segment(n, m));
    for (int i = 0; i < m; ++i) {
      if (!system.constraints.Active(static_cast<size_t>(i), options.t))
        (*R)(n + i) = lambda(i);
      else
        (*R)(n + i) -= system.constraints.Compliance(static_cast<size_t>(i)) * lambda(i);
    }
    sliding.Residual(lambda, s, R->tail(sliding.size()));
  };
  Eigen::VectorXd R;
  system.AcceptStep(r.q, velocity(r.q), options.t, data);  // the rotors' inflow at the guess
  residual(r.q, r.lambda, &R);
  r.initial_residual = R.lpNorm<Eigen::Infinity>();
  // options.stable: a walk in pseudo-time, K + μ M (the step of an implicit Euler;
  // pseudo-transient continuation). Newton heads for the nearest stationary point, stable or not:
  // on a generated teetering rotor at rest (`cosim rotor new --topology teetering --settle true`),
  // whose teeter is nearly neutral (gravity −3.8 N m/rad, the blades' centres just above the
  // hinge, against 350 kg m²), the settle's first step was 74 m, capped, and the iterates swung
  // between two states (residuals 7.45 and 33.0) for 400 iterations; on its shaft tilted 0.3 rad
  // the yoke went uphill through the far pad's plane, which then had to pull (−101 N), twelve
  // rounds over; its continuous twin settled level at +2.39°, balanced on its gravity and the
  // wind, from where it falls to its stop. A STATIC step of the MBDyn-like Puma, whose lag at
  // rest is neutral, converged or diverged (residual 3.5e4 after 20 iterations) on round-off in
  // its beam nodes' positions. μ is the step's trust region: raised until the step is
  // within max_step (a capped step distorts rigid bodies' directors) and goes where the loads
  // push, lowered by 4 after each step; the solve ends on a plain Newton step.
  Eigen::SparseMatrix<double> mass_N = system.mass;  // M in the q block of the Newton matrix
  mass_N.conservativeResize(N, N);
  double pseudo_mass = options.stable ? kPseudoMass : 0.0;
  for (r.iterations = 0; r.iterations < options.max_iterations; ++r.iterations) {
    TripletSink sink;
    StaticTangent(system, *data, r.q, r.lambda, frame, options.t, MW2, &sink);
    sliding.Tangent(n, &sink);
    const Eigen::SparseMatrix<double> K = sink.Build(N);
    NewtonStep step(K, mass_N, R, n, sliding.size());
    if (!step.Solve(options, &pseudo_mass)) {
      r.singular = true;
      break;
    }
    Eigen::VectorXd& delta = step.delta();
    const auto moves = [&] { return step.Moves(); };
    // Steps in q and s capped at options.max_step (metres, or director components): the first
    // steps from a flat start can be metres long where a soft mode meets a large load (a twisted
    // Puma blade in air: 13.8 m at the tip, then divergence); capped, Newton walks there. The
    // multipliers take their full step (linear in the residual: capping them too let a blade
    // drift under unbalanced centrifugal force to an unstable equilibrium).
    const double longest = moves();
    if (longest > options.max_step) {
      delta.head(n) *= options.max_step / longest;
      delta.tail(sliding.size()) *= options.max_step / longest;
    }
    // A sliding node's step through one of its guard planes is cut where it meets the first
    // (the whole step, scaled), and the solve stops there for the caller.
    delta *= sliding.GuardFraction(s, delta.tail(sliding.size()), &r.blocked_node, &r.blocked_guard);
    // Full Newton steps: a residual merit (forces in N beside constraint rows, an axial
    // stiffness 1e7 times the directors' second-order stretch) rejects the steps that converge.
    r.q += delta.head(n);
    r.lambda += delta.segment(n, m);
    s += delta.tail(sliding.size());
    system.AcceptStep(r.q, velocity(r.q), options.t, data);  // inflow of the new state, held in Newton
    residual(r.q, r.lambda, &R);
    if (!R.allFinite() || r.blocked_node >= 0) break;
    pseudo_mass *= 0.25;
    const double scale = 1.0 + std::max(r.q.lpNorm<Eigen::Infinity>(), s.lpNorm<Eigen::Infinity>());
    if (moves() > options.tolerance * scale) continue;
    if (pseudo_mass > 0.0) {  // still in pseudo-time: settled there, confirmed by plain Newton
      pseudo_mass = 0.0;
      continue;
    }
    if (!sliding.Anchored(r.lambda, s)) {  // converged with the proximal springs pulling: again from here
      sliding.Anchor(s);
      residual(r.q, r.lambda, &R);
      continue;
    }
    r.converged = true;
    ++r.iterations;
    break;
  }
  r.residual = R.lpNorm<Eigen::Infinity>();
  for (size_t k = 0; k < options.sliding.size(); ++k) r.node_positions.push_back(sliding.Position(k, s));
  return r;
}

std::string ResidualsText(const EquilibriumResult& r) {
  return "(residual " + interface::FormatNumber(r.residual) + " after " + std::to_string(r.iterations) +
         " Newton iterations, " + interface::FormatNumber(r.initial_residual) + " at the start)";
}

std::vector<Mode> LinearModes(const MultibodySystem& system, const SystemData& data, const Eigen::VectorXd& q,
                              const Eigen::VectorXd& lambda, double t, const SpinningFrame& frame, int count,
                              double zero_frequency) {
  const int n = system.coordinates, m = system.constraints.size();
  const Eigen::Matrix3d O = Skew(frame.omega);
  const Eigen::MatrixXd M = Eigen::MatrixXd(system.mass);
  Eigen::MatrixXd K = M * Eigen::MatrixXd(PerTriple(n, O * O)), C = 2.0 * M * Eigen::MatrixXd(PerTriple(n, O));
  {
    // Objective elements at q̇ = 0; the air at the absolute velocities W q̂ of the steady state
    // (see StaticEquilibrium): with q̇_abs = q̇ + W q̂ its K gains C_air W.
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
    DenseSink k(&K), c(&C);
    system.AddForceTangent(q, zero, t, data, 1.0, 0.0, &k);
    system.AddForceTangent(q, zero, t, data, 0.0, 1.0, &c);
    system.constraints.HessianTimesLambda(data.imposed, t, lambda, &k, 1.0);
    if (const AirLoads* air = system.air_loads; air != nullptr) {
      const Eigen::MatrixXd W = Eigen::MatrixXd(PerTriple(n, O));
      const Eigen::VectorXd v = W * WithoutOrigin(system, q, frame.origin);
      Eigen::MatrixXd Ca = Eigen::MatrixXd::Zero(n, n);  // the air's −∂f/∂q̇ at W q̂
      DenseSink ca(&Ca);
      air->AddTangent(q, v, t, data, 1.0, 0.0, &k);
      air->AddTangent(q, zero, t, data, -1.0, 0.0, &k);
      air->AddTangent(q, v, t, data, 0.0, 1.0, &ca);
      K += Ca * W;
      // C holds the air's damping at rest (from AddForceTangent): replace it by the one at W q̂.
      air->AddTangent(q, zero, t, data, 0.0, -1.0, &c);
      C += Ca;
    }
  }
  // Rows that hold (active, not regularised: a regularised row is a spring, already in K via
  // its multiplier's law only in time integration; here it is held rigid as well).
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(m, n);
  {
    DenseSink g(&G);
    system.constraints.Jacobian(data.imposed, q, t, &g, 0, 1.0);
  }
  for (int i = 0; i < m; ++i) {
    if (!system.constraints.Active(static_cast<size_t>(i), t)) G.row(i).setZero();
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(G.transpose());
  const int rank = static_cast<int>(qr.rank());
  const Eigen::MatrixXd Q = qr.householderQ();
  const Eigen::MatrixXd Z = Q.rightCols(n - rank);
  const int k = n - rank;
  const Eigen::MatrixXd Mr = Z.transpose() * M * Z, Kr = Z.transpose() * K * Z, Cr = Z.transpose() * C * Z;
  // First-order form E ż = F z, z = [y; ẏ], E = [I 0; 0 Mr], F = [0 I; −Kr −Cr]. The wanted modes
  // are the slowest, and the stiffest (a section's rotation against its shear stiffness, ω ~
  // 1e7 rad/s) would swamp them in a direct eigen-solve (absolute error ε |F|): shift and
  // invert, T = (F − σE)⁻¹ E, whose largest eigenvalues μ = 1/(λ − σ) are the slow modes, each
  // to a relative ε. σ = −1e-3 rad/s keeps T regular with rigid (λ = 0) modes present.
  const double sigma = -1e-3;
  Eigen::MatrixXd E = Eigen::MatrixXd::Identity(2 * k, 2 * k), F = Eigen::MatrixXd::Zero(2 * k, 2 * k);
  E.bottomRightCorner(k, k) = Mr;
  F.topRightCorner(k, k).setIdentity();
  F.bottomLeftCorner(k, k) = -Kr;
  F.bottomRightCorner(k, k) = -Cr;
  const Eigen::MatrixXd T = (F - sigma * E).partialPivLu().solve(E);
  const Eigen::EigenSolver<Eigen::MatrixXd> es(T, true);
  std::vector<Mode> modes;
  for (int i = 0; i < 2 * k; ++i) {
    const std::complex<double> mu = es.eigenvalues()(i);
    if (std::abs(mu) == 0.0) continue;  // an infinitely fast mode (a massless coordinate)
    const std::complex<double> lam = sigma + 1.0 / mu;
    if (lam.imag() <= 0.0 || std::abs(lam) < zero_frequency) continue;
    Mode mode;
    mode.eigenvalue = lam;
    mode.frequency = std::abs(lam);
    mode.damping = -lam.real() / std::abs(lam);
    const Eigen::VectorXcd y = es.eigenvectors().col(i).head(k);
    Eigen::VectorXcd dq = Z * y;
    Eigen::Index big = 0;
    dq.cwiseAbs().maxCoeff(&big);
    dq /= dq(big);
    mode.shape = dq.real();
    modes.push_back(std::move(mode));
  }
  std::sort(modes.begin(), modes.end(), [](const Mode& a, const Mode& b) { return a.frequency < b.frequency; });
  if (static_cast<int>(modes.size()) > count) modes.resize(static_cast<size_t>(count));
  return modes;
}

}  // namespace cosim::smooth
