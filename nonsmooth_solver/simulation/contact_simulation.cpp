#include "nonsmooth_solver/simulation/contact_simulation.h"

#include "interface/scenario/checks.h"

namespace cosim::nonsmooth {

ContactSimulation::ContactSimulation(const interface::ScenarioFile& file, const std::set<std::string>* only_nodes)
    : ContactStepper(file),
      model_(std::make_unique<const ContactModel>(BuildContactModel(file, only_nodes))),
      settings_(ReadMoreauJeanSettings(file)) {
  numerics_.CopyFrom(file.proto().numerics());
  interface::MaterializeDefaults(&numerics_);
  numerics_.clear_smooth();  // settings of the other solver are not used here
  // The fallback list actually used (the schema's default is an empty list).
  auto* lcp = numerics_.mutable_nonsmooth()->mutable_lcp();
  if (lcp->fallback_size() == 0) {
    for (LcpAlgorithm a : settings_.lcp.fallbacks) {
      lcp->add_fallback(a == LcpAlgorithm::kEnumerative ? scenario::LcpSettings::ENUMERATIVE
                                                        : scenario::LcpSettings::NEWTON_FB);
    }
  }
  integrator_ = std::make_unique<MoreauJean>(*model_, settings_, numerics_.start_time());
}

bool ContactSimulation::Impact(int node) const {
  const auto& contacts = model_->contacts;
  for (size_t c = 0; c < contacts.size(); ++c) {
    if (contacts[c].node == node && integrator_->impulses()(static_cast<Eigen::Index>(c)) > 0.0) return true;
  }
  return false;
}

void ContactSimulation::Advance(double t, double h) {
  integrator_->Step(t, h);
  // Penetration is the constraint violation of a unilateral contact.
  for (size_t c = 0; c < model_->contacts.size(); ++c) {
    max_penetration_ = std::max(max_penetration_, -integrator_->Gap(static_cast<int>(c)));
  }
}

void ContactSimulation::FillSummary(run::RunSummary* summary) const {
  const MoreauJeanStats& s = integrator_->stats();
  summary->mutable_numerics()->CopyFrom(numerics_);
  summary->set_max_constraint_violation(max_penetration_);
  auto* lcp = summary->mutable_lcp_iterations();
  lcp->set_total(static_cast<double>(s.lcp_iterations));
  lcp->set_mean_per_step(
      summary->steps() > 0 ? static_cast<double>(s.lcp_iterations) / static_cast<double>(summary->steps()) : 0.0);
  lcp->set_max_per_step(s.max_step_lcp_iterations);
  auto& counters = *summary->mutable_counters();
  counters["lcp_solves"] = static_cast<double>(s.lcp_solves);
  counters["lcp_fallbacks"] = static_cast<double>(s.lcp_fallbacks);
  counters["contact_activations"] = static_cast<double>(s.activations);
  counters["contact_nodes"] = static_cast<double>(model_->nodes.size());
  counters["contacts"] = static_cast<double>(model_->contacts.size());
}

void ContactSimulation::SetInterfaceStiffness(const Eigen::VectorXd& stiffness, const Eigen::VectorXd& reference) {
  if (stiffness.size() == 0) {
    integrator_->ClearInterfaceStiffness();
  } else {
    integrator_->SetInterfaceStiffness(stiffness, reference);
  }
}

bool ContactSimulation::Sensitivities(double h, Eigen::VectorXd* position, Eigen::VectorXd* velocity) const {
  *velocity = integrator_->velocity_sensitivity();
  *position = (h * settings_.theta) * *velocity;
  return true;
}

void ContactSimulation::WriteState(state::ContactState* s) const {
  const Eigen::VectorXd& impulse = integrator_->impulses();
  s->mutable_impulse()->Add(impulse.data(), impulse.data() + impulse.size());
  const Eigen::MatrixXd& friction = integrator_->friction_impulses();  // 3 × contacts, column-major
  s->mutable_friction_impulse()->Add(friction.data(), friction.data() + friction.size());
}

void ContactSimulation::ReadState(const state::ContactState& s) {
  MoreauJean::Checkpoint c;
  integrator_->SaveTo(&c);  // the sizes, and the driven frames as UseSavedState left them
  c.time = s.time();
  c.q = Eigen::Map<const Eigen::VectorXd>(s.q().data(), s.q_size());
  c.v = Eigen::Map<const Eigen::VectorXd>(s.v().data(), s.v_size());
  c.impulse = Eigen::Map<const Eigen::VectorXd>(s.impulse().data(), s.impulse_size());
  c.friction_impulse.setZero();
  if (s.friction_impulse_size() == c.friction_impulse.size()) {
    c.friction_impulse = Eigen::Map<const Eigen::MatrixXd>(s.friction_impulse().data(), c.friction_impulse.rows(),
                                                           c.friction_impulse.cols());
  }
  integrator_->Restore(c);
}

}  // namespace cosim::nonsmooth
