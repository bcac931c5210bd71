#pragma once
// A relaxation of the reactions (the coupling without interface Jacobians):
//
//   StepBegin → every peer: predicted reactions x_0 → k_0
//   for i = 0, 1, ...:
//     impose k_i on the interface points; CGα step from the step's start → multipliers → x̃_i
//     converged (RelaxationConvergence): accept the step
//     else x_{i+1} = relaxation(x_i, x̃_i) → every peer: Reactions(i+1) → Kinematics k_{i+1}
//
// with the relaxation constant, Aitken's or IQN-ILS (interface/coupling/relaxation.h). A solve
// the relaxed reactions make impossible is backtracked from the last iteration that solved.
#include <string>

#include "smooth_solver/coupling/convergence.h"
#include "smooth_solver/coupling/coupling_method.h"

namespace cosim::smooth {

class RelaxationMethod final : public CouplingMethod {
 public:
  RelaxationMethod(const CouplingSettings& settings, CouplingIterate* it, InterfaceRows* rows);

  void BeginStep() override { relaxation_.BeginStep(); }
  bool PreSolves() const override { return false; }
  void Predict(double /*h*/) override {}
  void Linearised(double /*h*/, bool /*solved*/) override {}
  bool PredictionAgrees(bool /*solved*/, CouplingIterationRecord* /*record*/) override { return false; }
  bool FreeFlight(double h) const override;
  void Impose(double h) override;
  bool WarmStart(int iteration) const override { return settings_.warm_start && iteration > 0; }
  bool Converged(int iteration, bool free_flight, CouplingIterationRecord* record, bool* skipped) override;
  void Next(double h, CouplingIterationRecord* record) override;
  bool Backtrack(int iteration, int backtrack, CouplingIterationRecord* record) override;
  const Eigen::VectorXd& HeldForce() const override { return it_->x; }
  void Forget() override { relaxation_.Forget(); }
  void WriteMemory(state::CoordinatorMemory* out) const override { relaxation_.Write(out->mutable_relaxation()); }
  std::string ReadMemory(const state::CoordinatorMemory& in) override;

 private:
  static constexpr int kMaxBacktracks = 4;  // per step

  const CouplingSettings& settings_;
  CouplingIterate* it_;
  InterfaceRows* rows_;
  interface::Relaxation relaxation_;
  RelaxationConvergence convergence_;
  // The reactions of the step's last iteration that solved, its answer x̃ and the kinematics it
  // was solved with (the previous iteration's, for the convergence test); the next x.
  Eigen::VectorXd solved_x_, previous_x_tilde_, previous_position_, x_next_;
};

}  // namespace cosim::smooth
