#pragma once
// Generalised-α on the stabilised index-2 form (after Arnold, Brüls & Cardona): the same
// Newmark/α updates as CGα, but the constraint is imposed at velocity level, Φ_q v + Φ_t = 0
// (multiplier λ), while the positions are projected back onto Φ(q) = 0 by a correction
// Φ_qᵀ ν of the Newmark position (multiplier ν) [Gear, Leimkuhler & Gupta 1985]:
//
//   (1 − αm) a_{n+1} + αm a_n = (1 − αf) v̇_{n+1} + αf v̇_n
//   v_{n+1} = v_n + h (1 − γ) a_n + h γ a_{n+1}
//   q_{n+1} = q_n + h v_n + h² (½ − β) a_n + h² β a_{n+1} + Φ_q(q_{n+1})ᵀ ν
//   M v̇_{n+1} + Φ_qᵀ λ = f(q_{n+1}, v_{n+1}, t_{n+1}),  Φ(q_{n+1}) = 0,  Φ_q v_{n+1} + Φ_t = 0.
//
// Unlike the index-3 form (integrator/cgalpha.h), the multipliers stay stable without
// numerical dissipation, so ρ∞ = 1 gives a non-dissipative, energy-conserving-in-the-mean
// scheme. Newton on (q, v̇, λ, ν) with the exact Jacobian, KLU with the pattern fixed once.
#include "smooth_solver/integrator/cgalpha.h"
#include "smooth_solver/integrator/elastic_step_force.h"

namespace cosim::smooth {

class CgAlphaIndex2 : public SmoothIntegrator {
 public:
  // `data`: the run's changing state (MakeData(system)), outliving the integrator.
  CgAlphaIndex2(const MultibodySystem& system, const SystemData& data, const CgAlphaSettings& settings,
                const DaeState& initial);

  int Step(double t, double h) override;
  IntegratorCapabilities capabilities() const override { return {}; }  // (none: see smooth_integrator.h)
  const DaeState& state() const override { return state_; }
  double ConstraintViolation(double t) const override;

 private:
  void Assemble(double t1, double cq, double cv);

  const MultibodySystem& system_;
  const SystemData& data_;
  CgAlphaSettings settings_;
  AlphaCoefficients coef_;
  DaeState state_;  // qddot holds v̇
  Eigen::VectorXd a_;
  ElasticStepForce elastic_;  // f̃_n of the elastic bodies (GEMM)
  DaeState next_;
  Eigen::VectorXd nu_, a_next_, q_newmark_, residual_, delta_, force_, scratch_;
  mutable Eigen::VectorXd violation_;
  Eigen::SparseMatrix<double> S_;
  KluSolver lu_;
};

}  // namespace cosim::smooth
