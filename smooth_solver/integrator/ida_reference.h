#pragma once
// The independent reference integrator: SUNDIALS IDA (variable-order, variable-step BDF) on
// the Gear–Gupta–Leimkuhler stabilised index-2 form of the same equations [Gear, Leimkuhler
// & Gupta 1985]:
//   q̇ = v − Φ_qᵀ μ,   M v̇ = f − Φ_qᵀ λ,   Φ_q v + Φ_t = 0,   Φ(q, t) = 0,
// whose extra multiplier μ keeps the positions on the constraint manifold (μ = 0 for the exact
// solution). IDA's unknowns for the multipliers are their time integrals Λ, Μ (λ = Λ̇, μ = Μ̇):
// the Newton matrix then carries c_j Φ_qᵀ in their columns, scaled like the rest, instead of
// O(1) columns against O(c_j) rows, which made IDA's Newton iteration fail at tolerances below
// 1e-8 (round-off in λ amplified by c_j ~ 1/h). Λ and Μ are left out of the error test.
// Exact Jacobian in a sparse matrix whose pattern is fixed once, solved by KLU.
#include <memory>

#include "smooth_solver/integrator/smooth_integrator.h"

namespace cosim::smooth {

struct IdaSettings {
  double relative_tolerance = 1e-6;
  double absolute_tolerance = 1e-8;
  long max_steps_per_output = 100000;
};

class IdaReference : public SmoothIntegrator {
 public:
  // `data`: the run's changing state (MakeData(system)), outliving the integrator.
  IdaReference(const MultibodySystem& system, const SystemData& data, const IdaSettings& settings,
               const DaeState& initial, double t0);
  ~IdaReference() override;

  // Integrates to t + h (IDA takes its own internal steps; the result is its interpolant at
  // t + h). Returns IDA's internal steps taken.
  int Step(double t, double h) override;
  IntegratorCapabilities capabilities() const override { return {}; }  // (none: see smooth_integrator.h)
  const DaeState& state() const override { return state_; }
  double ConstraintViolation(double t) const override;
  long internal_steps() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  DaeState state_;
};

}  // namespace cosim::smooth
