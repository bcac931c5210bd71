#include "nonsmooth_solver/model/contact_model.h"

#include <Eigen/Geometry>
#include <map>
#include <set>

#include "interface/scenario/checks.h"

namespace cosim::nonsmooth {

using interface::Checks;
using interface::ElementPath;
using interface::FormatNumber;
using interface::NameTable;
namespace sc = cosim::scenario;

BodyFrame DrivenFrame::At(double t) const {
  if (!(t1 > t0) || t >= t1) return end;
  if (t <= t0) return start;
  const double s = (t - t0) / (t1 - t0);
  BodyFrame f;
  f.origin = (1.0 - s) * start.origin + s * end.origin;
  f.velocity = (1.0 - s) * start.velocity + s * end.velocity;
  f.angular_velocity = (1.0 - s) * start.angular_velocity + s * end.angular_velocity;
  f.rotation = Eigen::Quaterniond(start.rotation).slerp(s, Eigen::Quaterniond(end.rotation)).toRotationMatrix();
  return f;
}

Eigen::Vector3d Obstacle::PointAt(double t, const ContactData& data) const {
  if (driven >= 0) {
    const DrivenFrame& d = data.frames[static_cast<size_t>(driven)];
    const BodyFrame f = d.At(t);
    return f.origin + f.rotation * d.point_body;
  }
  return point + t * velocity;
}

Eigen::Vector3d Obstacle::NormalAt(double t, const ContactData& data) const {
  if (driven >= 0) {
    const DrivenFrame& d = data.frames[static_cast<size_t>(driven)];
    return d.At(t).rotation * d.normal_body;
  }
  if (!moving || rotation_angle.IsZero()) return normal;
  return Eigen::AngleAxisd(rotation_angle.Value(t), rotation_axis) * normal;
}

Eigen::Vector3d Obstacle::TangentAt(double t, const ContactData& data) const {
  if (driven >= 0) {
    const DrivenFrame& d = data.frames[static_cast<size_t>(driven)];
    return d.At(t).rotation * d.tangent_body;
  }
  if (!moving || rotation_angle.IsZero()) return tangent;
  return Eigen::AngleAxisd(rotation_angle.Value(t), rotation_axis) * tangent;
}

Eigen::Vector3d Obstacle::VelocityAt(double t, const Eigen::Vector3d& x, const ContactData& data) const {
  if (driven >= 0) {
    const BodyFrame f = data.frames[static_cast<size_t>(driven)].At(t);
    return f.velocity + f.angular_velocity.cross(x - f.origin);
  }
  if (!moving) return Eigen::Vector3d::Zero();
  return velocity + rotation_angle.Derivative(t) * rotation_axis.cross(x - PointAt(t, data));
}

double Obstacle::GapRateBias(double t, const Eigen::Vector3d& x, const ContactData& data) const {
  // g = n·(x − p): dg/dt = n·ẋ − n·ṗ + ṅ·(x − p), with ṅ = ω × n, and
  // (ω × n)·r = −n·(ω × r): the bias is −n·(velocity of the plane's point at x).
  if (!moving) return 0.0;
  return -NormalAt(t, data).dot(VelocityAt(t, x, data));
}

double KineticEnergy(const ContactModel& model, const Eigen::VectorXd& v, int node) {
  double e = 0.0;
  for (size_t i = 0; i < model.nodes.size(); ++i) {
    if (node >= 0 && static_cast<size_t>(node) != i) continue;
    e += 0.5 * model.nodes[i].mass * v.segment<3>(3 * static_cast<Eigen::Index>(i)).squaredNorm();
  }
  return e;
}

double PotentialEnergy(const ContactModel& model, const Eigen::VectorXd& q, int node) {
  double e = 0.0;
  for (size_t i = 0; i < model.nodes.size(); ++i) {
    if (node >= 0 && static_cast<size_t>(node) != i) continue;
    const ContactNode& nd = model.nodes[i];
    const Eigen::Vector3d x = q.segment<3>(3 * static_cast<Eigen::Index>(i));
    e += -nd.mass * model.gravity.dot(x) + 0.5 * nd.stiffness * (x - nd.anchor).squaredNorm();
  }
  if (node < 0) {
    for (const NodeSpring& s : model.springs) {
      const Eigen::Vector3d stretch = q.segment<3>(3 * s.node1) - q.segment<3>(3 * s.node2) - s.rest_offset;
      e += 0.5 * s.stiffness * stretch.squaredNorm();
    }
  }
  return e;
}

namespace {

void BuildObstacles(const Checks& checks, const sc::Model& model, bool served, ContactModel* out, NameTable* names) {
  for (int i = 0; i < model.obstacles_size(); ++i) {
    const sc::Obstacle& o = model.obstacles(i);
    const std::string path = ElementPath("model.obstacles", i);
    Obstacle obstacle;
    obstacle.name = names->Declare(path + ".name", o.has_name(), o.name());
    obstacle.point = checks.Vector3(path + ".point", o.point(), std::nullopt);
    obstacle.normal = checks.Direction(path + ".normal", o.normal());
    // A tangent: the global axis least aligned with n, projected onto the plane.
    Eigen::Index least = 0;
    obstacle.normal.cwiseAbs().minCoeff(&least);
    const Eigen::Vector3d axis = Eigen::Vector3d::Unit(least);
    obstacle.tangent = (axis - axis.dot(obstacle.normal) * obstacle.normal).normalized();
    if (o.has_prescribed()) {
      const auto& m = o.prescribed();
      obstacle.moving = true;
      obstacle.velocity = checks.Vector3(path + ".prescribed.velocity", m.velocity(), Eigen::Vector3d::Zero());
      if (m.has_rotation_angle()) {
        obstacle.rotation_axis = checks.Direction(path + ".prescribed.rotation_axis", m.rotation_axis());
        obstacle.rotation_angle = TimeFunction::Build(checks, path + ".prescribed.rotation_angle", m.rotation_angle());
      }
    } else if (o.has_attached_to_body() && o.attached_to_body() != "ground") {
      if (!served) {
        checks.Fail(path + ".attached_to_body",
                    "an obstacle attached to body '" + o.attached_to_body() +
                        "' moves with the smooth model, which only a coupled run provides; a standalone contact "
                        "run needs a fixed or prescribed obstacle");
      }
      obstacle.moving = true;
      obstacle.driven = out->driven_frames++;
      obstacle.driven_body = o.attached_to_body();
    }
    out->obstacles.push_back(obstacle);
  }
}

void BuildNodes(const Checks& checks, const sc::Model& model, const NameTable& obstacle_names,
                const std::set<std::string>* only_nodes, ContactModel* out, NameTable* names) {
  for (int i = 0; i < model.contact_nodes_size(); ++i) {
    const sc::ContactNode& n = model.contact_nodes(i);
    if (only_nodes != nullptr && only_nodes->count(n.name()) == 0) continue;  // another process's
    const std::string path = ElementPath("model.contact_nodes", i);
    ContactNode node;
    node.name = names->Declare(path + ".name", n.has_name(), n.name());
    node.mass = checks.Positive(path + ".mass", n.has_mass(), n.mass(), "kg");
    node.position = checks.Vector3(path + ".position", n.position(), std::nullopt);
    node.velocity = checks.Vector3(path + ".velocity", n.velocity(), Eigen::Vector3d::Zero());
    node.constant_force =
        checks.Vector3(path + ".force", n.force(), Eigen::Vector3d::Zero()) + node.mass * out->gravity;
    if (n.force_function_size() != 0) {
      if (n.force_function_size() != 3) {
        checks.Fail(path + ".force_function",
                    "expected 3 functions (x, y, z), got " + std::to_string(n.force_function_size()));
      }
      for (int c = 0; c < 3; ++c) {
        node.force_function[static_cast<size_t>(c)] =
            TimeFunction::Build(checks, ElementPath(path + ".force_function", c), n.force_function(c));
      }
      node.has_time_force = true;
    }
    if (n.has_anchor()) {
      const auto& a = n.anchor();
      node.anchor = checks.Vector3(path + ".anchor.point", a.point(), std::nullopt);
      checks.Require(path + ".anchor.stiffness", a.has_stiffness(), "a stiffness in N/m");
      node.stiffness = checks.NonNegative(path + ".anchor.stiffness", a.stiffness(), "N/m");
      node.damping = checks.NonNegative(path + ".anchor.damping", a.damping(), "N s/m");
    }
    std::set<int> seen;
    for (int j = 0; j < n.contacts_size(); ++j) {
      const sc::ContactNode::Contact& c = n.contacts(j);
      const std::string cpath = ElementPath(path + ".contacts", j);
      Contact contact;
      contact.node = static_cast<int>(out->nodes.size());
      checks.Require(cpath + ".obstacle", c.has_obstacle(), "the name of an obstacle");
      contact.obstacle = obstacle_names.Find(cpath + ".obstacle", c.obstacle());
      if (!seen.insert(contact.obstacle).second) {
        checks.Fail(cpath + ".obstacle",
                    "node '" + node.name + "' already has a contact with obstacle '" + c.obstacle() + "'");
      }
      contact.restitution = checks.InRange(cpath + ".restitution", c.has_restitution(), c.restitution(), 0.0, 1.0);
      contact.friction = checks.NonNegative(cpath + ".friction", c.friction(), "Coulomb coefficient");
      contact.name = node.name + "/" + c.obstacle();
      out->contacts.push_back(contact);
    }
    out->nodes.push_back(node);
  }
}

void BuildProbes(const Checks& checks, const sc::Output& output, const NameTable& node_names, const ContactModel& model,
                 const std::set<std::string>& elsewhere, bool coupled, ContactModel* out) {
  std::map<std::string, int> contact_index;
  for (size_t c = 0; c < model.contacts.size(); ++c) contact_index[model.contacts[c].name] = static_cast<int>(c);
  NameTable probe_names(checks, "probe");
  for (int i = 0; i < output.probes_size(); ++i) {
    const sc::Probe& p = output.probes(i);
    const std::string path = ElementPath("output.probes", i);
    // Probes of entities that another process integrates are that process's; in a coupled run
    // the smooth model's quantities (constraint violation, reactions, joints...) are
    // smooth_solver's even without an entity.
    if (elsewhere.count(p.entity()) != 0) continue;
    // A probe of one of this process's nodes or contacts is this process's whatever its
    // quantity (smooth_solver leaves it alone): one it does not record is refused below, as in
    // a contact-only run, never dropped.
    const bool own_entity = node_names.Contains(p.entity()) || contact_index.count(p.entity()) != 0;
    if (coupled && !own_entity && p.quantity() != sc::Probe::POSITION && p.quantity() != sc::Probe::VELOCITY &&
        p.quantity() != sc::Probe::GAP && p.quantity() != sc::Probe::IMPULSE &&
        p.quantity() != sc::Probe::KINETIC_ENERGY && p.quantity() != sc::Probe::POTENTIAL_ENERGY &&
        p.quantity() != sc::Probe::TOTAL_ENERGY) {
      continue;
    }
    Probe probe;
    if (p.name() == "time") checks.Fail(path + ".name", "'time' is the first column already; choose another name");
    probe.name = probe_names.Declare(path + ".name", p.has_name(), p.name());
    const std::string entity = p.entity();
    auto node_entity = [&]() { return node_names.Find(path + ".entity", entity); };
    auto contact_entity = [&]() {
      auto it = contact_index.find(entity);
      if (it == contact_index.end()) {
        std::string known;
        for (const auto& [name, c] : contact_index) known += (known.empty() ? "" : ", ") + name;
        checks.Fail(path + ".entity", "no contact named '" + entity + "' (contacts are named node/obstacle" +
                                          (known.empty() ? "; the scenario has none)" : "; known: " + known + ")"));
      }
      return it->second;
    };
    switch (p.quantity()) {
      case sc::Probe::POSITION:
      case sc::Probe::VELOCITY:
        probe.kind = p.quantity() == sc::Probe::POSITION ? ProbeKind::kPosition : ProbeKind::kVelocity;
        probe.index = node_entity();
        probe.component = interface::ProbeComponent(checks, path, p, true);
        break;
      case sc::Probe::GAP:
      case sc::Probe::IMPULSE:
        probe.kind = p.quantity() == sc::Probe::GAP ? ProbeKind::kGap : ProbeKind::kImpulse;
        probe.index = contact_entity();
        probe.component = interface::ProbeComponent(checks, path, p, false);
        break;
      case sc::Probe::KINETIC_ENERGY:
      case sc::Probe::POTENTIAL_ENERGY:
      case sc::Probe::TOTAL_ENERGY:
        probe.kind = p.quantity() == sc::Probe::KINETIC_ENERGY     ? ProbeKind::kKineticEnergy
                     : p.quantity() == sc::Probe::POTENTIAL_ENERGY ? ProbeKind::kPotentialEnergy
                                                                   : ProbeKind::kTotalEnergy;
        probe.index = entity.empty() ? -1 : node_entity();
        probe.component = interface::ProbeComponent(checks, path, p, false);
        break;
      default:
        checks.Fail(path + ".quantity",
                    "a contact process records POSITION, VELOCITY, GAP, IMPULSE, KINETIC_ENERGY, POTENTIAL_ENERGY "
                    "or TOTAL_ENERGY, got " +
                        sc::Probe::Quantity_Name(p.quantity()));
    }
    out->probes.push_back(probe);
  }
}

void BuildSprings(const Checks& checks, const sc::Model& model, const NameTable& node_names,
                  const std::set<std::string>& elsewhere, ContactModel* out) {
  NameTable spring_names(checks, "node spring");
  for (int i = 0; i < model.node_springs_size(); ++i) {
    const sc::NodeSpring& s = model.node_springs(i);
    const std::string path = ElementPath("model.node_springs", i);
    const bool away1 = elsewhere.count(s.node1()) != 0, away2 = elsewhere.count(s.node2()) != 0;
    if (away1 && away2) continue;  // between another process's nodes
    if (away1 || away2) {
      checks.Fail(path, "node spring '" + s.name() + "' links '" + s.node1() + "' and '" + s.node2() +
                            "', which are in different contact processes; a spring must stay within one process");
    }
    NodeSpring spring;
    spring.name = spring_names.Declare(path + ".name", s.has_name(), s.name());
    checks.Require(path + ".node1", s.has_node1(), "the name of a contact node");
    checks.Require(path + ".node2", s.has_node2(), "the name of a contact node");
    spring.node1 = node_names.Find(path + ".node1", s.node1());
    spring.node2 = node_names.Find(path + ".node2", s.node2());
    if (spring.node1 == spring.node2) checks.Fail(path + ".node2", "links node '" + s.node2() + "' to itself");
    checks.Require(path + ".stiffness", s.has_stiffness(), "a stiffness in N/m");
    spring.stiffness = checks.NonNegative(path + ".stiffness", s.stiffness(), "N/m");
    spring.damping = checks.NonNegative(path + ".damping", s.damping(), "N s/m");
    const Eigen::Vector3d initial =
        out->nodes[static_cast<size_t>(spring.node1)].position - out->nodes[static_cast<size_t>(spring.node2)].position;
    spring.rest_offset = checks.Vector3(path + ".rest_offset", s.rest_offset(), initial);
    out->springs.push_back(spring);
  }
}

// Connected components of the node-spring graph, each with its nodes' contacts.
void BuildGroups(ContactModel* model) {
  const int n = static_cast<int>(model->nodes.size());
  std::vector<int> parent(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) parent[static_cast<size_t>(i)] = i;
  auto root = [&](int i) {
    while (parent[static_cast<size_t>(i)] != i) i = parent[static_cast<size_t>(i)];
    return i;
  };
  for (const NodeSpring& s : model->springs) parent[static_cast<size_t>(root(s.node1))] = root(s.node2);
  std::map<int, int> group_of_root;
  model->node_group.assign(static_cast<size_t>(n), 0);
  model->node_slot.assign(static_cast<size_t>(n), 0);
  for (int i = 0; i < n; ++i) {
    auto [it, inserted] = group_of_root.emplace(root(i), static_cast<int>(model->groups.size()));
    if (inserted) model->groups.emplace_back();
    NodeGroup& g = model->groups[static_cast<size_t>(it->second)];
    model->node_group[static_cast<size_t>(i)] = it->second;
    model->node_slot[static_cast<size_t>(i)] = static_cast<int>(g.nodes.size());
    g.nodes.push_back(i);
  }
  for (size_t c = 0; c < model->contacts.size(); ++c) {
    model->groups[static_cast<size_t>(model->node_group[static_cast<size_t>(model->contacts[c].node)])]
        .contacts.push_back(static_cast<int>(c));
  }
}

}  // namespace

ContactModel BuildContactModel(const interface::ScenarioFile& file, const std::set<std::string>* only_nodes) {
  const Checks checks(file);
  const sc::Scenario& s = file.proto();
  ContactModel model;
  model.gravity = checks.Vector3("model.gravity", s.model().gravity(), Eigen::Vector3d::Zero());

  NameTable obstacle_names(checks, "obstacle");
  NameTable node_names(checks, "contact node");
  BuildObstacles(checks, s.model(), only_nodes != nullptr, &model, &obstacle_names);
  if (s.model().contact_nodes_size() == 0) {
    checks.Fail("model.contact_nodes", "a contact process needs at least one contact node");
  }
  BuildNodes(checks, s.model(), obstacle_names, only_nodes, &model, &node_names);
  // Entities recorded elsewhere: another contact process's nodes and contacts, and in a
  // coupled run the smooth model's bodies, joints and elastic bodies (smooth_solver's).
  std::set<std::string> elsewhere;
  for (const auto& n : s.model().contact_nodes()) {
    if (only_nodes == nullptr || only_nodes->count(n.name()) != 0) continue;
    elsewhere.insert(n.name());
    for (const auto& c : n.contacts()) elsewhere.insert(n.name() + "/" + c.obstacle());
  }
  BuildSprings(checks, s.model(), node_names, elsewhere, &model);
  BuildGroups(&model);
  if (s.coupling().interface_nodes_size() > 0) {
    for (const auto& b : s.model().bodies()) elsewhere.insert(b.name());
    for (const auto& j : s.model().joints()) elsewhere.insert(j.name());
    for (const auto& e : s.model().elastic_bodies()) elsewhere.insert(e.name());
    for (const auto& f : s.model().forces()) elsewhere.insert(f.name());
    // Beams, their node bodies "<beam>.n<k>", aero surfaces and rotors.
    for (const auto& b : s.model().beams()) {
      elsewhere.insert(b.name());
      const int nodes = b.elements() * (b.nodes_per_element() - 1) + 1;
      for (int k = 0; k < nodes && k <= 100000; ++k) elsewhere.insert(b.name() + ".n" + std::to_string(k));
    }
    for (const auto& a : s.model().air().surfaces()) elsewhere.insert(a.name());
    for (const auto& r : s.model().air().rotors()) elsewhere.insert(r.name());
  }
  BuildProbes(checks, s.output(), node_names, model, elsewhere, s.coupling().interface_nodes_size() > 0, &model);
  return model;
}

}  // namespace cosim::nonsmooth
