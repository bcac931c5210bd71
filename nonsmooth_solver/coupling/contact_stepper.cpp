#include "nonsmooth_solver/coupling/contact_stepper.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>

#include "interface/base/errors.h"
#include "interface/base/input_file.h"
#include "interface/scenario/checks.h"

namespace cosim::nonsmooth {

using interface::FormatNumber;

void ContactStepper::Step(double t, double h) {
  // Standalone: a failed step leaves its state, and the run's saved state is the step's start.
  SaveStart();
  stepping_ = true;
  StepTentatively(t, h);
  CheckAccepted(t + h);
  stepping_ = false;
}

namespace {

void AddVector(const Eigen::Vector3d& v, google::protobuf::RepeatedField<double>* to) {
  for (int i = 0; i < 3; ++i) to->Add(v(i));
}

Eigen::Vector3d Vector(const google::protobuf::RepeatedField<double>& v) { return Eigen::Vector3d(v[0], v[1], v[2]); }

}  // namespace

bool ContactStepper::UseSavedState(const interface::ScenarioFile& file, const std::string& process) {
  scenario_name_ = interface::ScenarioName(file);
  process_ = process;
  if (!file.proto().numerics().has_initial_state()) return false;
  const std::string place = "numerics.initial_state";
  std::filesystem::path path = file.PathBeside(file.proto().numerics().initial_state());
  if (!process.empty()) path = path.parent_path() / process / "final_state.pb";
  const std::string own = process.empty() ? std::string()
                                          : " (a coupled run's contact process '" + process +
                                                "' reads its own beside the smooth solver's state)";
  const interface::InputFile bytes = interface::ReadInputFile(path, interface::kMaxStateBytes);
  if (!bytes.ok()) file.Fail(place, bytes.why + "; expected a final_state.pb of a contact process" + own);
  state::ContactState s;
  if (!s.ParseFromString(bytes.text)) {
    file.Fail(place, "'" + path.string() + "' is not a readable final_state.pb of a contact process" + own);
  }
  const ContactModel& model = this->model();
  auto refuse = [&](const std::string& what) {
    file.Fail(place, "'" + path.string() + "' " + what + "; expected a state written by a run of this scene");
  };
  if (s.scenario() != scenario_name_)
    refuse("is a state of scenario '" + interface::EchoedText(s.scenario()) + "', not of '" + scenario_name_ + "'");
  if (s.process() != process)
    refuse("is the state of process '" + interface::EchoedText(s.process()) + "', not of '" + process + "'");
  if (s.method() != MethodName()) {
    refuse("was written by the " + interface::EchoedText(s.method()) + " method, and this process runs " +
           MethodName());
  }
  bool same_nodes = s.nodes_size() == static_cast<int>(model.nodes.size());
  for (int n = 0; same_nodes && n < s.nodes_size(); ++n)
    same_nodes = s.nodes(n) == model.nodes[static_cast<size_t>(n)].name;
  const int nodes = static_cast<int>(model.nodes.size()), contacts = static_cast<int>(model.contacts.size());
  if (!same_nodes || s.q_size() != 3 * nodes || s.v_size() != 3 * nodes || s.contacts() != contacts ||
      s.impulse_size() != contacts || s.attached_size() != model.driven_frames ||
      (s.friction_impulse_size() != 0 && s.friction_impulse_size() != 3 * contacts) ||
      (s.impact_speed_size() != 0 && s.impact_speed_size() != contacts)) {
    refuse("holds " + std::to_string(s.nodes_size()) + " nodes, " + std::to_string(s.contacts()) + " contacts and " +
           std::to_string(s.attached_size()) + " attached obstacles; this process has " + std::to_string(nodes) + ", " +
           std::to_string(contacts) + " and " + std::to_string(model.driven_frames) + " (the same nodes in order)");
  }
  interface::Checks(file).StateTime("the contact state '" + path.string() + "'", s.time(), time());
  auto finite = [](const google::protobuf::RepeatedField<double>& v) {
    return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
  };
  if (!finite(s.q()) || !finite(s.v()) || !finite(s.impulse()) || !finite(s.friction_impulse()) ||
      !finite(s.impact_speed())) {
    refuse("holds a non-finite value");
  }
  std::vector<DrivenFrame>& frames = mutable_data()->frames;
  for (const Obstacle& o : model.obstacles) {
    if (o.driven < 0) continue;
    const state::ContactState::AttachedObstacle& a = s.attached(o.driven);
    if (a.obstacle() != o.name || a.point_size() != 3 || a.normal_size() != 3 || a.tangent_size() != 3 ||
        a.origin_size() != 3 || a.rotation_size() != 9 || a.velocity_size() != 3 || a.angular_velocity_size() != 3 ||
        !finite(a.point()) || !finite(a.normal()) || !finite(a.tangent()) || !finite(a.origin()) ||
        !finite(a.rotation()) || !finite(a.velocity()) || !finite(a.angular_velocity())) {
      refuse("does not hold the body-frame geometry of obstacle '" + o.name + "' as attached obstacle " +
             std::to_string(o.driven));
    }
    DrivenFrame& d = frames[static_cast<size_t>(o.driven)];
    d.point_body = Vector(a.point());
    d.normal_body = Vector(a.normal());
    d.tangent_body = Vector(a.tangent());
    BodyFrame saved;
    saved.origin = Vector(a.origin());
    saved.rotation = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(a.rotation().data());
    saved.velocity = Vector(a.velocity());
    saved.angular_velocity = Vector(a.angular_velocity());
    d.StartAt(saved, s.time());
  }
  ReadState(s);
  return true;
}

void ContactStepper::EndOutput() {
  if (output_folder_.empty()) return;
  if (stepping_) RestoreStart();
  state::ContactState s;
  s.set_scenario(scenario_name_);
  s.set_process(process_);
  s.set_method(MethodName());
  s.set_time(time());
  const ContactModel& model = this->model();
  for (const ContactNode& n : model.nodes) s.add_nodes(n.name);
  s.mutable_q()->Add(positions().data(), positions().data() + positions().size());
  s.mutable_v()->Add(velocities().data(), velocities().data() + velocities().size());
  s.set_contacts(static_cast<int>(model.contacts.size()));
  std::vector<const Obstacle*> attached(static_cast<size_t>(model.driven_frames), nullptr);
  for (const Obstacle& o : model.obstacles) {
    if (o.driven >= 0) attached[static_cast<size_t>(o.driven)] = &o;
  }
  for (size_t i = 0; i < attached.size(); ++i) {
    const DrivenFrame& d = data().frames[i];
    state::ContactState::AttachedObstacle* a = s.add_attached();
    a->set_obstacle(attached[i] != nullptr ? attached[i]->name : "");
    AddVector(d.point_body, a->mutable_point());
    AddVector(d.normal_body, a->mutable_normal());
    AddVector(d.tangent_body, a->mutable_tangent());
    const BodyFrame f = d.At(time());
    AddVector(f.origin, a->mutable_origin());
    for (int r = 0; r < 3; ++r) AddVector(f.rotation.row(r).transpose(), a->mutable_rotation());
    AddVector(f.velocity, a->mutable_velocity());
    AddVector(f.angular_velocity, a->mutable_angular_velocity());
  }
  WriteState(&s);
  interface::WriteFinalState(output_folder_, s);
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

ContactStepper::ContactStepper(const interface::ScenarioFile& file)
    : penetration_limit_(interface::Checks(file).Positive(
          "numerics.nonsmooth.max_penetration", true, file.proto().numerics().nonsmooth().max_penetration(), "m")) {}

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
    if (gap < -penetration_limit_) {
      const Contact& contact = model.contacts[c];
      throw NumericalError("contact '" + model.nodes[static_cast<size_t>(contact.node)].name + "/" +
                           model.obstacles[static_cast<size_t>(contact.obstacle)].name + "' is " + FormatNumber(-gap) +
                           " m through its obstacle after the step to t = " + FormatNumber(t) +
                           " s, more than numerics.nonsmooth.max_penetration = " + FormatNumber(penetration_limit_) +
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
