#pragma once
// penalty_solver's contact method: the contact nodes of a ContactModel (point masses, anchor
// and node springs, fixed / prescribed / body-attached planes) with each contact a compliant
// Flores / Hunt–Crossley law instead of Newton's impact law [rotor-sailing paper, Eq. (8)]:
//   f = K δⁿ (1 + χ δ̇/δ̇⁻) n,   χ = 8(1 − e_law)/(5 e_law),
// where e_law is solved so that the law rebounds with the contact's Newton e (LawRestitution):
// as K grows, the penalty process converges to the nonsmooth one. Time stepping: the implicit
// trapezoidal rule (Moreau–Jean's θ = 1/2 without the impulses), `numerics.penalty.substeps`
// substeps per coupling step, each solved by Newton on the end velocities with the law's exact
// tangents:
//   M (v₁ − v₀) = h/2 (f(t₀, q₀, v₀) + f(t₁, q₁, v₁)) + h F_ext,   q₁ = q₀ + h/2 (v₀ + v₁).
// With the coordinator's reaction F_ext (the step-averaged force) held over the step, this is
// the trapezoidal rule of the coupled system whatever the mass split between the node and the
// smooth body it is tied to; an explicit sub-stepped integrator of the light node alone would
// not be (it resolves the contact force inside the step against a reaction that cannot
// follow it: observed 20 % too high rebounds). δ̇⁻ is the approach speed at the start of the
// substep in which a contact starts (at least speed_threshold), kept while it lasts.
//
// The law's forces are finite: a node's velocity never jumps (Impact is false), so the
// coordinator treats the contact as a smooth force; the step must resolve the contact (ten
// steps or more per contact duration) for the coupled run to be accurate.
//
// It exists to prove that the contact process can be swapped without touching the smooth side:
// it speaks the same protocol through the same ContactServer (docs/protocol.md).
#include <Eigen/Core>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "interface/contact/hunt_crossley.h"
#include "nonsmooth_solver/coupling/contact_stepper.h"

namespace cosim::nonsmooth {

class PenaltySimulation : public ContactStepper {
 public:
  // `only_nodes`: see BuildContactModel. Throws InputError naming the field for missing or bad
  // numerics.penalty settings and for friction (this process is frictionless).
  explicit PenaltySimulation(const interface::ScenarioFile& file, const std::set<std::string>* only_nodes = nullptr);

  void Advance(double t, double h) override;
  void FillSummary(run::RunSummary* summary) const override;

  const ContactModel& model() const override { return *model_; }
  void SaveStart() override { saved_ = state_; }
  void RestoreStart() override { state_ = saved_; }
  void SetExternalForces(const Eigen::VectorXd& forces) override { external_ = forces; }
  ContactData* mutable_data() override { return &data_; }
  const ContactData& data() const override { return data_; }
  double time() const override { return state_.time; }
  void StartNodeAt(int node, const Eigen::Vector3d& x, const Eigen::Vector3d& v) override {
    state_.q.segment<3>(3 * static_cast<Eigen::Index>(node)) = x;
    state_.v.segment<3>(3 * static_cast<Eigen::Index>(node)) = v;
  }
  const Eigen::VectorXd& positions() const override { return state_.q; }
  const Eigen::VectorXd& velocities() const override { return state_.v; }
  bool Impact(int node) const override;
  std::string SolverName() const override;
  std::string MethodName() const override { return "penalty"; }

  double Gap(int contact) const override;
  double GapRate(int contact) const override;
  double Impulse(int contact) const override { return state_.impulse(contact); }

 protected:
  // The last step's impulses and each contact's onset speed, with the nodes' state.
  void WriteState(state::ContactState* s) const override;
  void ReadState(const state::ContactState& s) override;

 private:
  struct State {
    double time = 0.0;
    Eigen::VectorXd q, v;
    Eigen::VectorXd impact_speed;  // δ̇⁻ per contact (while in contact)
    Eigen::VectorXd impulse;       // ∫ f dt per contact over the last step
  };
  // f(t, q, v) into `f` (3 per node, F_ext included) and the contact forces' magnitudes into
  // `contact`; with `K`, `C`: −∂f/∂q and −∂f/∂v (the bias of a moving plane's velocity field
  // is left out of ∂f/∂q: Newton converges a little slower on spinning planes, to the same
  // solution).
  void Forces(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& v, Eigen::VectorXd* f,
              Eigen::VectorXd* contact, Eigen::MatrixXd* K, Eigen::MatrixXd* C) const;
  void Substep(double t, double h);

  std::unique_ptr<const ContactModel> model_;
  std::vector<interface::HuntCrossleyLaw> laws_;  // per contact
  int substeps_ = 1;
  scenario::Numerics numerics_;
  State state_, saved_;
  ContactData data_;  // the driven obstacles' frames: the step's input (the coupling server's), not saved
  Eigen::VectorXd external_;
  Eigen::VectorXd mass_;  // 3 per node
  // Workspace of one substep.
  Eigen::VectorXd f0_, f1_, c0_, c1_, q1_, v1_, residual_, dv_;
  Eigen::MatrixXd K_, C_, J_;
  double max_penetration_ = 0.0;
  long long substeps_taken_ = 0, newton_iterations_ = 0;
};

}  // namespace cosim::nonsmooth
