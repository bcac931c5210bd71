#include "smooth_solver/integrator/cgalpha_index2.h"

#include <cmath>
#include <limits>

#include "interface/base/errors.h"
#include "smooth_solver/linear_algebra/fixed_pattern_matrix.h"
#include "smooth_solver/linear_algebra/hub_columns.h"

namespace cosim::smooth {

CgAlphaIndex2::CgAlphaIndex2(const MultibodySystem& system, const SystemData& data, const CgAlphaSettings& settings,
                             const DaeState& initial)
    : system_(system),
      data_(data),
      settings_(settings),
      coef_(AlphaCoefficients::FromRhoInf(settings.rho_inf)),
      state_(initial),
      elastic_(system, settings.gemm, coef_.alpha_f) {
  a_ = state_.qddot;
  elastic_.Reset(state_.q);
  const int n = system.coordinates, m = system.constraints.size();
  next_ = state_;
  nu_ = Eigen::VectorXd::Zero(m);
  a_next_.resize(n);
  q_newmark_.resize(n);
  residual_.resize(2 * n + 2 * m);
  delta_.resize(2 * n + 2 * m);
  force_.resize(n);
  scratch_.resize(m);

  // Pattern of the scaled Newton matrix (rows R1..R4, columns Δq, Δv̇, Δλ, Δν); t = −∞ keeps
  // every row a locked joint may release.
  const double always = -std::numeric_limits<double>::infinity();
  const ConstraintSet& cs = system.constraints;
  const ImposedValues& imposed = data.imposed;
  PatternSink p;
  OffsetSink r1_vdot(&p, 0, n), r2(&p, n, 0), r4(&p, 2 * n + m, 0), r4_vdot(&p, 2 * n + m, n);
  for (int i = 0; i < 2 * n + 2 * m; ++i) p.Add(i, i, 0.0);
  cs.HessianPattern(&p);
  system.ForcePattern(&p);
  AddSparse(system.mass, 1.0, &r1_vdot);
  system.ForcePattern(&r1_vdot);
  cs.JacobianTranspose(imposed, system.q0, always, &p, 2 * n, 1.0);
  cs.HessianPattern(&r2);
  for (int i = 0; i < n; ++i) p.Add(n + i, i, 0.0);  // R2: I in the Δq columns
  cs.JacobianTranspose(imposed, system.q0, always, &r2, 2 * n + m, 1.0);
  cs.Jacobian(imposed, system.q0, always, &p, 2 * n, 1.0);
  cs.Jacobian(imposed, system.q0, always, &r4, 0, 1.0);
  cs.Jacobian(imposed, system.q0, always, &r4_vdot, 0, 1.0);
  S_ = p.Build(2 * n + 2 * m, 2 * n + 2 * m);
  // A hub's coordinates and rates (a rotor's: hub_columns.h) ordered last.
  const int rigid = system.rigid_coordinates();
  std::vector<int> group = RigidBodyGroups(rigid, static_cast<int>(S_.cols()));
  for (int j = 0; j < rigid; ++j) group[static_cast<size_t>(n + j)] = group[static_cast<size_t>(j)];
  lu_.Analyze(S_, HubColumns(S_, group));
}

double CgAlphaIndex2::ConstraintViolation(double t) const {
  violation_.resize(system_.constraints.size());  // sized once
  system_.constraints.Evaluate(data_.imposed, state_.q, t, violation_);
  return violation_.size() > 0 ? violation_.lpNorm<Eigen::Infinity>() : 0.0;
}

void CgAlphaIndex2::Assemble(double t1, double cq, double cv) {
  const int n = system_.coordinates, m = system_.constraints.size();
  const ConstraintSet& cs = system_.constraints;
  const ImposedValues& imposed = data_.imposed;
  MatrixSink sink(&S_);  // zeroed by Step, which added the elastic tangent
  // R1 × c_q: [c_q (Σλ∇²φ − ∂f/∂q), M − c_v ∂f/∂v (column ÷ c_q), Φ_qᵀ (column ÷ c_q), 0].
  cs.HessianTimesLambda(imposed, t1, next_.lambda, &sink, cq);
  system_.AddForceTangent(next_.q, next_.qdot, t1, data_, cq, 0.0, &sink, /*include_elastic=*/false);
  OffsetSink r1_vdot(&sink, 0, n);
  AddSparse(system_.mass, 1.0, &r1_vdot);
  system_.AddForceTangent(next_.q, next_.qdot, t1, data_, 0.0, cv, &r1_vdot, /*include_elastic=*/false);
  cs.JacobianTranspose(imposed, next_.q, t1, &sink, 2 * n, 1.0);
  // R2: [I − Σν∇²φ, −I (column ÷ c_q: −c_q I / c_q), 0, −Φ_qᵀ].
  OffsetSink r2(&sink, n, 0);
  for (int i = 0; i < n; ++i) {
    sink.Add(n + i, i, 1.0);
    sink.Add(n + i, n + i, -1.0);
  }
  cs.HessianTimesLambda(imposed, t1, nu_, &r2, -1.0);
  cs.JacobianTranspose(imposed, next_.q, t1, &r2, 2 * n + m, -1.0);
  // R3: [Φ_q, 0, 0, 0].
  cs.Jacobian(imposed, next_.q, t1, &sink, 2 * n, 1.0);
  // R4 × c_q/c_v: [(c_q/c_v) ∂(Φ_q v + Φ_t)/∂q, Φ_q (c_v Φ_q × c_q/c_v ÷ c_q), 0, 0].
  OffsetSink r4(&sink, 2 * n + m, 0, cq / cv), r4_vdot(&sink, 2 * n + m, n);
  cs.VelocityConstraintJacobian(imposed, next_.q, next_.qdot, t1, &r4, 0);
  cs.Jacobian(imposed, next_.q, t1, &r4_vdot, 0, 1.0);
  // Released joints: identity rows for their λ and ν.
  cs.AddReleasedDiagonal(t1, &sink, 2 * n);
  cs.AddReleasedDiagonal(t1, &sink, 2 * n + m);
}

int CgAlphaIndex2::Step(double t, double h) {
  const int n = system_.coordinates, m = system_.constraints.size();
  const ConstraintSet& cs = system_.constraints;
  const ImposedValues& imposed = data_.imposed;
  const double t1 = t + h;
  const double ca = (1.0 - coef_.alpha_f) / (1.0 - coef_.alpha_m);  // ∂a_{n+1}/∂v̇_{n+1}
  const double cv = h * coef_.gamma * ca, cq = h * h * coef_.beta * ca;
  if (RestartAtRelease(system_, data_, t, t1, &state_)) {  // a joint let go: new α history
    a_ = state_.qddot;
    elastic_.Reset(state_.q);
  }
  // Predictor: v̇_{n+1} = v̇_n, λ_{n+1} = λ_n, ν = 0.
  next_.qddot = state_.qddot;
  next_.lambda = state_.lambda;
  for (int i = 0; i < m; ++i) {
    if (!cs.Active(static_cast<size_t>(i), t1)) next_.lambda(i) = 0.0;
  }
  nu_.setZero();
  auto update_kinematics = [&] {
    a_next_ = ((1.0 - coef_.alpha_f) * next_.qddot + coef_.alpha_f * state_.qddot - coef_.alpha_m * a_) /
              (1.0 - coef_.alpha_m);
    next_.qdot = state_.qdot + h * ((1.0 - coef_.gamma) * a_ + coef_.gamma * a_next_);
    q_newmark_ = state_.q + h * state_.qdot + h * h * ((0.5 - coef_.beta) * a_ + coef_.beta * a_next_);
  };
  update_kinematics();
  next_.q = q_newmark_;

  for (int iteration = 1; iteration <= settings_.max_iterations; ++iteration) {
    auto r1 = residual_.head(n), r2 = residual_.segment(n, n);
    system_.Force(next_.q, next_.qdot, t1, data_, force_, /*include_elastic=*/false);
    for (Eigen::Index k = 0; k < S_.nonZeros(); ++k) S_.valuePtr()[k] = 0.0;
    {
      MatrixSink sink(&S_);
      elastic_.Add(state_.q, next_.q, force_, cq, &sink);  // force_ −= f̃_{n+1}; its tangent × c_q
    }
    r1.noalias() = system_.mass * next_.qddot;
    r1 -= force_;
    cs.AddJacobianTransposeTimes(imposed, next_.q, t1, next_.lambda, r1);
    r1 *= cq;
    r2 = next_.q - q_newmark_;
    force_.setZero();  // reused as scratch for Φ_qᵀ ν
    cs.AddJacobianTransposeTimes(imposed, next_.q, t1, nu_, force_);
    r2 -= force_;
    cs.Evaluate(imposed, next_.q, t1, residual_.segment(2 * n, m));
    cs.JacobianTimes(imposed, next_.q, t1, next_.qdot, residual_.tail(m));
    cs.TimeDerivative(imposed, next_.q, t1, scratch_);
    residual_.tail(m) = (residual_.tail(m) + scratch_) * (cq / cv);
    Assemble(t1, cq, cv);
    if (!lu_.Factorize(S_)) {
      throw NumericalError("CGα (index 2): the iteration matrix is singular at t = " + std::to_string(t1) + " s");
    }
    delta_ = -residual_;
    lu_.SolveInPlace(delta_);
    next_.q += delta_.head(n);
    next_.qddot += delta_.segment(n, n) / cq;
    next_.lambda += delta_.segment(2 * n, m) / cq;
    nu_ += delta_.tail(m);
    update_kinematics();
    // Converged: small position correction, constraints met at position and velocity level.
    cs.Evaluate(imposed, next_.q, t1, scratch_);
    const double phi = m > 0 ? scratch_.lpNorm<Eigen::Infinity>() : 0.0;
    cs.JacobianTimes(imposed, next_.q, t1, next_.qdot, residual_.tail(m));  // reused as scratch
    cs.TimeDerivative(imposed, next_.q, t1, scratch_);
    const double vel_error = m > 0 ? (residual_.tail(m) + scratch_).lpNorm<Eigen::Infinity>() * h : 0.0;
    const double dq = delta_.head(n).lpNorm<Eigen::Infinity>();
    if (!std::isfinite(dq)) break;
    if (dq <= settings_.tolerance * (1.0 + next_.q.lpNorm<Eigen::Infinity>()) && phi <= settings_.tolerance &&
        vel_error <= settings_.tolerance) {
      a_ = a_next_;
      elastic_.Accept(state_.q, next_.q);
      std::swap(state_, next_);
      return iteration;
    }
  }
  throw NumericalError("CGα (index 2): Newton did not converge in " + std::to_string(settings_.max_iterations) +
                       " iterations at t = " + std::to_string(t1) + " s; reduce the step or raise the iteration limit");
}

}  // namespace cosim::smooth
