#include "nonsmooth_solver/coupling/contact_stepper.h"

#include "interface/scenario/checks.h"

namespace cosim::nonsmooth {

std::vector<std::string> ContactStepper::ProbeNames() const {
  std::vector<std::string> names;
  for (const auto& p : model().probes) names.push_back(p.name);
  return names;
}

void ContactStepper::Probe(std::vector<double>* values) const {
  const ContactModel& model = this->model();
  for (size_t i = 0; i < model.probes.size(); ++i) {
    const nonsmooth::Probe& p = model.probes[i];
    double value = 0.0;
    switch (p.kind) {
      case ProbeKind::kPosition:
      case ProbeKind::kVelocity: {
        const Eigen::VectorXd& x = p.kind == ProbeKind::kPosition ? positions() : velocities();
        value = interface::PickComponent(Eigen::Vector3d(x.segment<3>(3 * p.index)), p.component);
        break;
      }
      case ProbeKind::kGap: value = Gap(p.index); break;
      case ProbeKind::kImpulse: value = Impulse(p.index); break;
      case ProbeKind::kKineticEnergy: value = KineticEnergy(model, velocities(), p.index); break;
      case ProbeKind::kPotentialEnergy: value = PotentialEnergy(model, positions(), p.index); break;
      case ProbeKind::kTotalEnergy:
        value = KineticEnergy(model, velocities(), p.index) + PotentialEnergy(model, positions(), p.index);
        break;
    }
    (*values)[i] = value;
  }
}

}  // namespace cosim::nonsmooth
