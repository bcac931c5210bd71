#include "smooth_solver/simulation/node_rest.h"

#include <map>

#include "interface/scenario/message_tree.h"
#include "interface/scenario/scenario_file.h"
#include "interface/scenario/time_function.h"

namespace cosim::smooth {

namespace sc = scenario;
using interface::ElementPath;
using interface::FormatNumber;

namespace {

std::string Format(const Eigen::Vector3d& v) {
  return "[" + FormatNumber(v(0)) + ", " + FormatNumber(v(1)) + ", " + FormatNumber(v(2)) + "]";
}

// The plane of obstacle i at time t, as the contact process places it at the start: fixed and
// attached ones as written; prescribed ones moved by their velocity and turned by their angle
// (contact_model.h, Obstacle::PointAt and NormalAt).
void PlaneAt(const interface::Checks& checks, const sc::Model& model, int i, double t, Eigen::Vector3d* point,
             Eigen::Vector3d* normal) {
  const sc::Obstacle& o = model.obstacles(i);
  const std::string path = ElementPath("model.obstacles", i);
  *point = checks.Vector3(path + ".point", o.point(), std::nullopt);
  *normal = checks.Direction(path + ".normal", o.normal());
  if (!o.has_prescribed()) return;
  const sc::Obstacle::PrescribedMotion& m = o.prescribed();
  *point += t * checks.Vector3(path + ".prescribed.velocity", m.velocity(), Eigen::Vector3d::Zero());
  if (m.has_rotation_angle()) {
    const interface::TimeFunction angle =
        interface::TimeFunction::Build(checks, path + ".prescribed.rotation_angle", m.rotation_angle());
    const Eigen::Vector3d axis = checks.Direction(path + ".prescribed.rotation_axis", m.rotation_axis());
    *normal = Eigen::AngleAxisd(angle.Value(t), axis) * *normal;
  }
}

}  // namespace

std::vector<RestingNode> ReadRestingNodes(const interface::Checks& checks, const MultibodySystem& system, double t,
                                          const SpinningFrame& spin) {
  const sc::Model& model = checks.file().proto().model();
  std::map<std::string, int> node_index, obstacle_index;
  for (int i = 0; i < model.contact_nodes_size(); ++i) node_index[model.contact_nodes(i).name()] = i;
  for (int i = 0; i < model.obstacles_size(); ++i) obstacle_index[model.obstacles(i).name()] = i;
  const Eigen::Vector3d gravity = checks.Vector3("model.gravity", model.gravity(), Eigen::Vector3d::Zero());
  std::vector<RestingNode> out;
  for (const InterfacePoint& point : system.interface_points) {
    const auto found = node_index.find(point.contact_node);
    if (found == node_index.end()) {
      checks.Fail("coupling.interface_nodes", "no contact node named '" + point.contact_node + "'");
    }
    const sc::ContactNode& n = model.contact_nodes(found->second);
    RestingNode r;
    r.node = n.name();
    r.path = ElementPath("model.contact_nodes", found->second);
    for (int s = 0; s < model.node_springs_size(); ++s) {
      const sc::NodeSpring& spring = model.node_springs(s);
      if (spring.node1() == r.node || spring.node2() == r.node) {
        checks.Fail("numerics.smooth.settle",
                    "contact node '" + r.node + "' hangs on node spring " + ElementPath("model.node_springs", s) +
                        ": its rest depends on nodes the settle does not move; start the run from a saved state "
                        "(numerics.initial_state) instead, or remove settle");
      }
    }
    r.position = checks.Vector3(r.path + ".position", n.position(), std::nullopt);
    const double mass = checks.Positive(r.path + ".mass", n.has_mass(), n.mass(), "kg");
    const Eigen::Vector3d arm = r.position - spin.origin;
    r.load = mass * gravity + checks.Vector3(r.path + ".force", n.force(), Eigen::Vector3d::Zero()) -
             mass * spin.omega.cross(spin.omega.cross(arm));
    Eigen::Matrix3d spin_skew;
    spin_skew << 0, -spin.omega.z(), spin.omega.y(), spin.omega.z(), 0, -spin.omega.x(), -spin.omega.y(),
        spin.omega.x(), 0;
    r.stiffness = -mass * spin_skew * spin_skew;
    const Eigen::Vector3d velocity = checks.Vector3(r.path + ".velocity", n.velocity(), Eigen::Vector3d::Zero());
    const Eigen::Vector3d frame_velocity = spin.omega.cross(arm);
    if ((velocity - frame_velocity).norm() > 1e-9 * (1.0 + frame_velocity.norm())) {
      checks.Fail(r.path + ".velocity", "is " + Format(velocity) + " m/s; a settled start has contact node '" + r.node +
                                            "' at rest in the frame spinning with the rotor, moving with it at " +
                                            Format(frame_velocity) + " m/s");
    }
    if (n.force_function_size() == 3) {
      for (int c = 0; c < 3; ++c) {
        r.load(c) +=
            interface::TimeFunction::Build(checks, ElementPath(r.path + ".force_function", c), n.force_function(c))
                .Value(t);
      }
    } else if (n.force_function_size() != 0) {
      checks.Fail(r.path + ".force_function",
                  "expected 3 functions (x, y, z), got " + std::to_string(n.force_function_size()));
    }
    if (n.has_anchor()) {
      const Eigen::Vector3d anchor = checks.Vector3(r.path + ".anchor.point", n.anchor().point(), std::nullopt);
      const double k = checks.NonNegative(r.path + ".anchor.stiffness", n.anchor().stiffness(), "N/m");
      r.load -= k * (r.position - anchor);
      r.stiffness -= k * Eigen::Matrix3d::Identity();
    }
    for (int c = 0; c < n.contacts_size(); ++c) {
      const auto o = obstacle_index.find(n.contacts(c).obstacle());
      if (o == obstacle_index.end()) {
        checks.Fail(ElementPath(r.path + ".contacts", c) + ".obstacle",
                    "no obstacle named '" + n.contacts(c).obstacle() + "'");
      }
      RestingNode::Plane plane;
      plane.obstacle = n.contacts(c).obstacle();
      plane.friction = n.contacts(c).friction();
      PlaneAt(checks, model, o->second, t, &plane.point, &plane.normal);
      plane.gap = plane.normal.dot(r.position - plane.point);
      r.planes.push_back(plane);
    }
    out.push_back(r);
  }
  return out;
}

namespace {

// The normals of the planes `carrying` (indices into node.planes), as columns.
Eigen::MatrixXd Normals(const RestingNode& node, const std::vector<int>& carrying) {
  Eigen::MatrixXd normals(3, static_cast<Eigen::Index>(carrying.size()));
  for (size_t i = 0; i < carrying.size(); ++i)
    normals.col(static_cast<Eigen::Index>(i)) = node.planes[static_cast<size_t>(carrying[i])].normal;
  return normals;
}

}  // namespace

void RestingNode::MoveTo(const Eigen::Vector3d& x) {
  load += stiffness * (x - position);
  position = x;
  for (Plane& p : planes) p.gap = p.normal.dot(x - p.point);
  moved = true;
}

std::string WhyNotResting(const RestingNode& node, const Eigen::Vector3d& force, double touch,
                          std::vector<int>* carrying, Eigen::VectorXd* push) {
  // F + Σ R_i n_i = 0 with R_i >= 0 over the touching planes (least squares in R).
  const Eigen::Vector3d f = force + node.load;
  carrying->clear();
  for (size_t i = 0; i < node.planes.size(); ++i) {
    if (node.planes[i].gap <= touch) carrying->push_back(static_cast<int>(i));
  }
  *push = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(carrying->size()));
  if (!carrying->empty()) *push = Normals(node, *carrying).colPivHouseholderQr().solve(-f);
  Eigen::Vector3d rest = f;
  double cone = 0.0, least = 0.0;
  for (size_t i = 0; i < carrying->size(); ++i) {
    const RestingNode::Plane& p = node.planes[static_cast<size_t>((*carrying)[i])];
    const double r = (*push)(static_cast<Eigen::Index>(i));
    rest += r * p.normal;
    cone += p.friction * std::max(r, 0.0);
    least = std::min(least, r);
  }
  const double tolerance = 1e-3 * f.norm() + 1e-6;
  if (least < -tolerance) {
    return "its planes would have to pull it (normal reaction " + FormatNumber(least) +
           " N): the smooth model lifts it off";
  }
  if (rest.norm() > cone + tolerance) {
    return (carrying->empty() ? std::string("that force would move it")
                              : "the part of it along no plane's normal, " + Format(rest) + " N, would move it") +
           (cone > 0.0 ? " (more than friction holds, " + FormatNumber(cone) + " N)" : std::string());
  }
  return {};
}

Eigen::MatrixXd FreeDirections(const RestingNode& node, const std::vector<int>& carrying) {
  if (carrying.empty()) return Eigen::Matrix3d::Identity();
  const Eigen::MatrixXd normals = Normals(node, carrying);
  // The left singular vectors beyond the normals' rank span the directions along every plane.
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(normals, Eigen::ComputeFullU);
  Eigen::Index rank = 0;
  for (Eigen::Index i = 0; i < svd.singularValues().size(); ++i) {
    if (svd.singularValues()(i) > 1e-9 * svd.singularValues()(0)) ++rank;
  }
  return svd.matrixU().rightCols(3 - rank);
}

Eigen::Vector3d OnPlanes(const RestingNode& node, const std::vector<int>& carrying) {
  // The least change δ with n_iᵀ(x + δ − p_i) = 0 for every plane: δ = −N⁺ g.
  if (carrying.empty()) return node.position;
  Eigen::VectorXd gaps(static_cast<Eigen::Index>(carrying.size()));
  for (size_t i = 0; i < carrying.size(); ++i)
    gaps(static_cast<Eigen::Index>(i)) = node.planes[static_cast<size_t>(carrying[i])].gap;
  return node.position - Normals(node, carrying).transpose().completeOrthogonalDecomposition().solve(gaps);
}

void CheckNodesRest(const interface::Checks& checks, const std::vector<RestingNode>& nodes,
                    const std::vector<Eigen::Vector3d>& forces, double touch) {
  const std::string place = "numerics.smooth.settle";
  for (size_t k = 0; k < nodes.size(); ++k) {
    const RestingNode& node = nodes[k];
    for (const RestingNode::Plane& p : node.planes) {
      if (p.gap >= -touch) continue;
      checks.Fail(node.moved ? place : node.path + ".position",
                  "contact node '" + node.node + "' " + (node.moved ? "settles " : "starts ") + FormatNumber(-p.gap) +
                      " m inside obstacle '" + p.obstacle + "'; a settled start needs it on or above its planes");
    }
    std::vector<int> carrying;
    Eigen::VectorXd push;
    const std::string why = WhyNotResting(node, forces[k], touch, &carrying, &push);
    if (why.empty()) continue;
    std::string names;
    for (int i : carrying) names += (names.empty() ? "'" : ", '") + node.planes[static_cast<size_t>(i)].obstacle + "'";
    checks.Fail(place,
                "contact node '" + node.node + "' (" + node.path + ") cannot rest " +
                    (node.moved ? "where the settle moved it, " : "where it starts, ") + Format(node.position) +
                    " m: the settled smooth model and its own load push it with " + Format(forces[k] + node.load) +
                    " N, and " +
                    (carrying.empty() ? std::string("it touches no plane to hold it")
                                      : "the planes it touches (" + names + ") hold only pushes along their normals") +
                    ": " + why +
                    (node.moved ? ". Remove settle" : ". Start the node where a plane carries it, or remove settle"));
  }
}

}  // namespace cosim::smooth
