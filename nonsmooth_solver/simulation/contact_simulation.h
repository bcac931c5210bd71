#pragma once
// A standalone contact process run: the contact model, its Moreau–Jean integrator and the
// probes, behind the run contract's Simulation interface.
#include <memory>
#include <set>

#include "interface/run/run_driver.h"
#include "nonsmooth_solver/coupling/contact_stepper.h"
#include "nonsmooth_solver/integrator/moreau_jean.h"
#include "nonsmooth_solver/model/contact_model.h"

namespace cosim::nonsmooth {

class ContactSimulation : public ContactStepper {
 public:
  // `only_nodes`: see BuildContactModel (a coupled run's contact process with its own nodes).
  explicit ContactSimulation(const interface::ScenarioFile& file, const std::set<std::string>* only_nodes = nullptr);

  void Advance(double t, double h) override;
  void FillSummary(run::RunSummary* summary) const override;

  const ContactModel& model() const override { return *model_; }
  const MoreauJean& integrator() const { return *integrator_; }
  MoreauJean& mutable_integrator() { return *integrator_; }

  // ContactStepper (the coupling server's view).
  void SaveStart() override { integrator_->SaveTo(&start_); }
  void RestoreStart() override { integrator_->Restore(start_); }
  void SetExternalForces(const Eigen::VectorXd& forces) override { integrator_->SetExternalForces(forces); }
  ContactData* mutable_data() override { return integrator_->mutable_data(); }
  const ContactData& data() const override { return integrator_->data(); }
  double time() const override { return integrator_->time(); }
  void StartNodeAt(int node, const Eigen::Vector3d& x, const Eigen::Vector3d& v) override {
    integrator_->SetNodeState(node, x, v);
  }
  const Eigen::VectorXd& positions() const override { return integrator_->positions(); }
  const Eigen::VectorXd& velocities() const override { return integrator_->velocities(); }
  bool Impact(int node) const override;
  double Gap(int contact) const override { return integrator_->Gap(contact); }
  double GapRate(int contact) const override { return integrator_->GapRate(contact); }
  double Impulse(int contact) const override { return integrator_->impulses()(contact); }
  std::string SolverName() const override { return "nonsmooth_solver (Moreau-Jean, LCP via Siconos Numerics)"; }
  std::string MethodName() const override { return "moreau_jean"; }
  bool SupportsInterfaceJacobians() const override { return true; }
  void EnableInterfaceJacobians() override { integrator_->set_compute_sensitivities(true); }
  void SetInterfaceStiffness(const Eigen::VectorXd& stiffness, const Eigen::VectorXd& reference) override;
  const Eigen::VectorXd* AppliedForces() const override { return &integrator_->applied_forces(); }
  // Moreau–Jean: q_{k+1} = q_k + h(θ v_{k+1} + (1−θ) v_k), so ∂q/∂f = hθ ∂v/∂f.
  bool Sensitivities(double h, Eigen::VectorXd* position, Eigen::VectorXd* velocity) const override;

 protected:
  // The last step's impulses, normal and tangential (3 per contact), with the nodes' state.
  void WriteState(state::ContactState* s) const override;
  void ReadState(const state::ContactState& s) override;

 private:
  std::unique_ptr<const ContactModel> model_;  // stable address for the integrator
  MoreauJeanSettings settings_;                // numerics.nonsmooth
  std::unique_ptr<MoreauJean> integrator_;
  scenario::Numerics numerics_;  // as used, defaults filled in
  double max_penetration_ = 0.0;
  MoreauJean::Checkpoint start_;
};

}  // namespace cosim::nonsmooth
