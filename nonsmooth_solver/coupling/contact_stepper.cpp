#include "nonsmooth_solver/coupling/contact_stepper.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "interface/run/errors.h"
#include "interface/scenario/checks.h"

namespace cosim::nonsmooth {

using interface::FormatNumber;

void ContactStepper::Step(double t, double h) {
  StepTentatively(t, h);
  CheckAccepted(t + h);
}

void ContactStepper::StepTentatively(double t, double h) {
  Advance(t, h);
  const ContactModel& model = this->model();
  const Eigen::VectorXd& q = positions();
  const Eigen::VectorXd& v = velocities();
  for (size_t n = 0; n < model.nodes.size(); ++n) {
    const Eigen::Index i = 3 * static_cast<Eigen::Index>(n);
    if (!q.segment<3>(i).allFinite() || !v.segment<3>(i).allFinite()) {
      throw NumericalError("contact node '" + model.nodes[n].name +
                           "' has a non-finite position or velocity after "
                           "the step to t = " +
                           FormatNumber(t + h) +
                           " s (inputs too large for double precision, or "
                           "the step too long)");
    }
  }
}

double ContactStepper::TimeToContact(double resting_speed) const {
  double earliest = std::numeric_limits<double>::infinity();
  for (size_t c = 0; c < model().contacts.size(); ++c) {
    const int i = static_cast<int>(c);
    const double gap = Gap(i), rate = GapRate(i);
    if (gap <= 0.0 || Impulse(i) > 0.0) {
      // Closed: an event under way (the node still moving against or off the plane: 0), or a
      // node resting on it (left out: a blade lying on its stop is smooth motion).
      if (std::abs(rate) > resting_speed) return 0.0;
      continue;
    }
    if (rate < 0.0) earliest = std::min(earliest, gap / -rate);
  }
  return earliest;
}

void ContactStepper::CheckAccepted(double t) const {
  const ContactModel& model = this->model();
  for (size_t c = 0; c < model.contacts.size(); ++c) {
    const double gap = Gap(static_cast<int>(c));
    if (gap < -model.max_penetration) {
      const Contact& contact = model.contacts[c];
      throw NumericalError("contact '" + model.nodes[static_cast<size_t>(contact.node)].name + "/" +
                           model.obstacles[static_cast<size_t>(contact.obstacle)].name + "' is " + FormatNumber(-gap) +
                           " m through its obstacle after the step to t = " + FormatNumber(t) +
                           " s, more than numerics.nonsmooth.max_penetration = " + FormatNumber(model.max_penetration) +
                           " m: the step is too long for the motion (or the contact too soft)");
    }
  }
}

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
      case ProbeKind::kGap:
        value = Gap(p.index);
        break;
      case ProbeKind::kImpulse:
        value = Impulse(p.index);
        break;
      case ProbeKind::kKineticEnergy:
        value = KineticEnergy(model, velocities(), p.index);
        break;
      case ProbeKind::kPotentialEnergy:
        value = PotentialEnergy(model, positions(), p.index);
        break;
      case ProbeKind::kTotalEnergy:
        value = KineticEnergy(model, velocities(), p.index) + PotentialEnergy(model, positions(), p.index);
        break;
    }
    (*values)[i] = value;
  }
}

void ContactStepper::Visual(interface::VisualFrame* frame) const {
  using interface::VisualFrame;
  const ContactModel& m = model();
  const Eigen::VectorXd& x = positions();
  std::vector<int> node_contact(m.nodes.size(), 0), obstacle_contact(m.obstacles.size(), 0);
  for (size_t c = 0; c < m.contacts.size(); ++c) {
    const int k = static_cast<int>(c);
    if (Gap(k) <= 0.0 || Impulse(k) != 0.0) {
      node_contact[static_cast<size_t>(m.contacts[c].node)] = 1;
      obstacle_contact[static_cast<size_t>(m.contacts[c].obstacle)] = 1;
    }
  }
  for (size_t n = 0; n < m.nodes.size(); ++n) {
    frame->AddCell(VisualFrame::kVertex, {frame->AddPoint(x.segment<3>(3 * static_cast<Eigen::Index>(n)))},
                   VisualFrame::Kind::kContactNode, static_cast<int>(n), node_contact[n]);
    frame->Name(VisualFrame::Kind::kContactNode, static_cast<int>(n), m.nodes[n].name);
  }
  // A plane is infinite: drawn as the square (its side twice the largest distance of its nodes'
  // projections from its point, at least 0.2 m) centred on its point, in the plane's tangents.
  // Only the planes this process's nodes meet: the scenario's others belong to other processes.
  for (size_t o = 0; o < m.obstacles.size(); ++o) {
    const Obstacle& ob = m.obstacles[o];
    const Eigen::Vector3d p = ob.PointAt(time(), data()), normal = ob.NormalAt(time(), data());
    const Eigen::Vector3d t1 = ob.TangentAt(time(), data()), t2 = normal.cross(t1);
    double half = 0.1;
    bool met = false;
    for (const Contact& c : m.contacts) {
      if (c.obstacle != static_cast<int>(o)) continue;
      met = true;
      const Eigen::Vector3d d = x.segment<3>(3 * c.node) - p;
      half = std::max(half, 2.0 * (d - d.dot(normal) * normal).norm());
    }
    if (!met) continue;
    frame->AddSquare(p, t1, t2, half, VisualFrame::Kind::kObstacle, static_cast<int>(o), obstacle_contact[o]);
    frame->Name(VisualFrame::Kind::kObstacle, static_cast<int>(o), ob.name);
  }
}

}  // namespace cosim::nonsmooth
