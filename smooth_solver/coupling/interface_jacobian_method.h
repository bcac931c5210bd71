#pragma once
// Interface Jacobians (docs/protocol.md; the default when every peer offers them): a pre-solve
// linearises the smooth side (x̂, k̂, E = ∂x/∂k per node), the peers step with that implicit
// force law and answer with the force they held and their sensitivities S, and the smooth step
// solves with k = k̃ + S (x − x̃) on its interface rows; the step is accepted when its force is the
// one the peers held (a Newton iteration on the interface, one exchange a step while no contact
// set changes). The peers' answer linearised in the force is Kübler & Schiehlen's; imposing it
// through the coupling constraint, Schweizer & Lu's.
#include <string>
#include <vector>

#include "smooth_solver/coupling/convergence.h"
#include "smooth_solver/coupling/coupling_method.h"

namespace cosim::smooth {

class InterfaceJacobianMethod final : public CouplingMethod {
 public:
  // `it`, `memory`: the coordinator's step and memory; `rows`: the interface rows it imposes on;
  // `integrator`: the smooth side whose factorisation gives the stiffness E; `link`: the peers
  // (the frames they stepped with).
  InterfaceJacobianMethod(const MultibodySystem& system, CgAlpha* integrator, const PeerLink& link,
                          const StepReaction& reaction, const CouplingSettings& settings, CouplingIterate* it,
                          const CouplingMemory* memory, InterfaceRows* rows);

  void BeginStep() override {}
  bool PreSolves() const override { return true; }
  void Predict(double h) override;
  void Linearised(double h, bool solved) override;
  bool PredictionAgrees(bool solved, CouplingIterationRecord* record) override;
  bool FreeFlight(double /*h*/) const override { return false; }
  void Impose(double h) override;
  bool WarmStart(int /*iteration*/) const override { return true; }
  bool Converged(int iteration, bool free_flight, CouplingIterationRecord* record, bool* skipped) override;
  void Next(double h, CouplingIterationRecord* record) override;
  bool Backtrack(int /*iteration*/, int /*backtrack*/, CouplingIterationRecord* /*record*/) override { return false; }
  const Eigen::VectorXd& HeldForce() const override { return it_->answers.applied; }
  void Forget() override {}
  void WriteMemory(state::CoordinatorMemory* /*out*/) const override {}
  std::string ReadMemory(const state::CoordinatorMemory& /*in*/) override { return {}; }

  // What goes with x to the peers: the smooth side's stiffness E per point and the positions k̂
  // it was linearised at.
  const std::vector<Eigen::Matrix3d>& stiffness() const { return stiffness_; }
  const Eigen::VectorXd& linearised_at() const { return sent_position_; }

 private:
  // The point sent next (x̂, k̂) from the last solve, and the stiffness E there.
  void LineariseAtSolve(double h);
  // The smooth side's linearisation for the peers: stiffness E = ∂x/∂k of each point with its
  // own peer's compliance taken out, from the last factorisation (cached while it lasts).
  void UpdateStiffness(double h);
  // The axes of the body carrying interface point `point` in `state` (identity for an elastic node).
  Eigen::Matrix3d BodyAxes(int point, const DaeState& state) const;

  const MultibodySystem& system_;
  CgAlpha* integrator_;
  const PeerLink& link_;
  const StepReaction& reaction_;
  const CouplingSettings& settings_;
  CouplingIterate* it_;
  const CouplingMemory* memory_;
  InterfaceRows* rows_;
  InterfaceAgreement agreement_;
  // The stiffness E sent per point and the positions k̂ it was taken at; the smooth side's own
  // response ∂λ/∂x from the last factorisation (its factorisation count and step) and its
  // body's axes then.
  std::vector<Eigen::Matrix3d> stiffness_, response_, response_axes_;
  Eigen::VectorXd sent_position_;
  long long response_factorizations_ = -1;
  double response_h_ = 0.0;
};

}  // namespace cosim::smooth
