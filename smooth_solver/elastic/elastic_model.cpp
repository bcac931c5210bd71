#include "smooth_solver/elastic/elastic_model.h"

#include <Eigen/Geometry>
#include <cmath>

#include "interface/base/errors.h"

namespace cosim::smooth {

using interface::Checks;
using interface::ElementPath;
using interface::FormatNumber;
namespace sc = cosim::scenario;

int ElasticBodySpec::FindPoint(const Checks& checks, const std::string& path, const std::string& point) const {
  if (point == "tip_centre" || point == "root_centre") {
    const int node = point == "tip_centre" ? body.mesh().tip_centre : body.mesh().root_centre;
    if (node < 0) checks.Fail(path, "'" + point + "' exists on beam meshes only; give a node index");
    return node;
  }
  char* end = nullptr;
  const long node = std::strtol(point.c_str(), &end, 10);
  if (point.empty() || *end != '\0' || node < 0 || node >= body.node_count()) {
    checks.Fail(path, "expected a node index in [0, " + std::to_string(body.node_count() - 1) +
                          "], \"tip_centre\" or \"root_centre\", got '" + point + "'");
  }
  return static_cast<int>(node);
}

namespace {

// Rotation taking +x onto `axis` (the smallest one).
Eigen::Matrix3d AlongAxis(const Eigen::Vector3d& axis) {
  return Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitX(), axis).toRotationMatrix();
}

// Hex27 elements per body: each keeps its 81 × 81 tangent and its Gauss-point data.
constexpr double kMaxElements = 1e5;

int PositiveCount(const Checks& checks, const std::string& path, bool has, int value, const std::string& what) {
  checks.Require(path, has, what);
  if (value < 1) checks.Fail(path, "must be at least 1, got " + std::to_string(value));
  return value;
}

// A beam-shaped mesh: a box of elements along an axis, with its twist.
ElasticMesh ReadBeamMesh(const Checks& checks, const sc::ElasticBody::BeamMesh& b, const std::string& mesh_path) {
  const double length = checks.Positive(mesh_path + ".length", b.has_length(), b.length(), "m");
  const double chord = checks.Positive(mesh_path + ".chord", b.has_chord(), b.chord(), "m");
  const double thickness = checks.Positive(mesh_path + ".thickness", b.has_thickness(), b.thickness(), "m");
  const int along = PositiveCount(checks, mesh_path + ".elements_along", b.has_elements_along(), b.elements_along(),
                                  "the number of elements along the beam");
  const int across = PositiveCount(checks, mesh_path + ".elements_across", true, b.elements_across(), "");
  // Counted in double: along × across² overflows an int long before memory runs out.
  const double elements = static_cast<double>(along) * across * across;
  if (elements > kMaxElements) {
    checks.Fail(mesh_path,
                "elements_along × elements_across² = " + interface::FormatNumber(elements) +
                    " hex27 elements; at most " + interface::FormatNumber(kMaxElements) +
                    " per body (each needs ~60 kB for its tangent: the mesh would not fit this kind of machine)");
  }
  ElasticMesh mesh = BeamMesh(length, chord, thickness, along, across, across, {b.twist().begin(), b.twist().end()});
  const Eigen::Vector3d root = checks.Vector3(mesh_path + ".root", b.root(), Eigen::Vector3d::Zero());
  const Eigen::Matrix3d R =
      b.axis().empty() ? Eigen::Matrix3d::Identity() : AlongAxis(checks.Direction(mesh_path + ".axis", b.axis()));
  mesh.nodes = (R * mesh.nodes).colwise() + root;
  return mesh;
}

// A general mesh: node coordinates and 27 node indices per element.
ElasticMesh ReadGeneralMesh(const Checks& checks, const sc::ElasticBody::GeneralMesh& g, const std::string& mesh_path) {
  ElasticMesh mesh;
  if (g.node_coordinates_size() == 0 || g.node_coordinates_size() % 3 != 0) {
    checks.Fail(mesh_path + ".node_coordinates",
                "expected 3 coordinates per node, got " + std::to_string(g.node_coordinates_size()) + " numbers");
  }
  if (g.element_nodes_size() == 0 || g.element_nodes_size() % 27 != 0) {
    checks.Fail(mesh_path + ".element_nodes",
                "expected 27 node indices per element, got " + std::to_string(g.element_nodes_size()) + " numbers");
  }
  const int mesh_elements = g.element_nodes_size() / 27;  // (whole elements: checked above)
  if (mesh_elements > kMaxElements) {
    checks.Fail(mesh_path + ".element_nodes", std::to_string(mesh_elements) + " hex27 elements; at most " +
                                                  interface::FormatNumber(kMaxElements) + " per body");
  }
  const int nodes = g.node_coordinates_size() / 3;
  mesh.nodes = Eigen::Map<const Eigen::Matrix3Xd>(g.node_coordinates().data(), 3, nodes);
  for (int el = 0; el < g.element_nodes_size() / 27; ++el) {
    std::array<int, 27> element{};
    for (int a = 0; a < 27; ++a) {
      const int node = g.element_nodes(27 * el + a);
      if (node < 0 || node >= nodes) {
        checks.Fail(ElementPath(mesh_path + ".element_nodes", 27 * el + a),
                    "node index " + std::to_string(node) + " outside [0, " + std::to_string(nodes - 1) + "]");
      }
      element[static_cast<size_t>(a)] = node;
    }
    mesh.elements.push_back(element);
  }
  return mesh;
}

// The clamps of an elastic body: its nodes (a face of a beam mesh, or listed) tied to the ground
// or a rigid body.
void ReadClamps(const Checks& checks, const sc::ElasticBody& e, const std::string& path,
                const std::vector<std::string>& rigid_bodies, ElasticBodySpec* spec) {
  const ElasticMesh& mesh = spec->body.mesh();
  for (int c = 0; c < e.clamps_size(); ++c) {
    const auto& cl = e.clamps(c);
    const std::string cpath = ElementPath(path + ".clamps", c);
    ElasticBodySpec::Clamp clamp;
    checks.Require(cpath + ".body", cl.has_body(), "\"ground\" or the name of a rigid body");
    if (cl.body() != "ground") {
      int found = -1;
      for (size_t b = 0; b < rigid_bodies.size(); ++b) {
        if (rigid_bodies[b] == cl.body()) found = static_cast<int>(b);
      }
      if (found < 0) checks.Fail(cpath + ".body", "no rigid body named '" + cl.body() + "'");
      clamp.rigid_body = found;
    }
    if (cl.has_face()) {
      if (mesh.root_face.empty()) checks.Fail(cpath + ".face", "faces exist on beam meshes only; give nodes { ... }");
      if (cl.face() != "root" && cl.face() != "tip") {
        checks.Fail(cpath + ".face", "expected \"root\" or \"tip\", got '" + cl.face() + "'");
      }
      clamp.nodes = cl.face() == "root" ? mesh.root_face : mesh.tip_face;
    } else if (cl.has_nodes()) {
      for (int k = 0; k < cl.nodes().index_size(); ++k) {
        const int node = cl.nodes().index(k);
        if (node < 0 || node >= spec->body.node_count()) {
          checks.Fail(ElementPath(cpath + ".nodes.index", k), "node " + std::to_string(node) +
                                                                  " is outside the body (" +
                                                                  std::to_string(spec->body.node_count()) + " nodes)");
        }
        clamp.nodes.push_back(node);
      }
    } else {
      checks.Fail(cpath, "give face: \"root\"/\"tip\" or nodes { index: ... }");
    }
    spec->clamps.push_back(clamp);
  }
}

// The loads on an elastic body's nodes.
void ReadLoads(const Checks& checks, const sc::ElasticBody& e, const std::string& path, ElasticBodySpec* spec) {
  for (int l = 0; l < e.loads_size(); ++l) {
    const auto& load = e.loads(l);
    const std::string lpath = ElementPath(path + ".loads", l);
    int node = -1;
    if (load.has_node()) {
      node = spec->FindPoint(checks, lpath + ".node", std::to_string(load.node()));
    } else if (load.has_face_centre()) {
      node = spec->FindPoint(checks, lpath + ".face_centre", load.face_centre() + "_centre");
    } else {
      checks.Fail(lpath, "give node: N or face_centre: \"tip\"/\"root\"");
    }
    ElasticBodySpec::Load built_load;
    built_load.node = node;
    built_load.force = checks.Vector3(lpath + ".force", load.force(), std::nullopt);
    if (load.has_factor()) {
      built_load.factor = interface::TimeFunction::Build(checks, lpath + ".factor", load.factor());
      built_load.time_varying = true;
    }
    spec->loads.push_back(std::move(built_load));
  }
}

}  // namespace

std::vector<ElasticBodySpec> BuildElasticBodies(const Checks& checks, const sc::Model& model,
                                                const std::vector<std::string>& rigid_bodies) {
  std::vector<ElasticBodySpec> out;
  interface::NameTable names(checks, "elastic body");
  for (const std::string& b : rigid_bodies) names.Add("model.bodies", b);  // one name space with rigid bodies
  for (int i = 0; i < model.elastic_bodies_size(); ++i) {
    const sc::ElasticBody& e = model.elastic_bodies(i);
    const std::string path = ElementPath("model.elastic_bodies", i);
    ElasticBodySpec spec;
    spec.name = names.Declare(path + ".name", e.has_name(), e.name());
    checks.Require(path + ".material", e.has_material(), "material { density: ... young: ... poisson: ... }");
    ElasticMaterial material;
    const auto& m = e.material();
    material.density = checks.Positive(path + ".material.density", m.has_density(), m.density(), "kg/m^3");
    material.young = checks.Positive(path + ".material.young", m.has_young(), m.young(), "Pa");
    material.poisson = checks.InRange(path + ".material.poisson", m.has_poisson(), m.poisson(), -1.0, 0.5, true, true);
    spec.strain_damping = checks.NonNegative(path + ".strain_damping", e.strain_damping(), "dimensionless");
    spec.retardation_time = checks.NonNegative(path + ".retardation_time", e.retardation_time(), "s");

    ElasticMesh mesh;
    std::string mesh_path;
    if (e.has_beam()) {
      mesh_path = path + ".beam";
      mesh = ReadBeamMesh(checks, e.beam(), mesh_path);
    } else if (e.has_general()) {
      mesh_path = path + ".general";
      mesh = ReadGeneralMesh(checks, e.general(), mesh_path);
    } else {
      checks.Fail(path, "give a mesh: beam { ... } or general { ... }");
    }
    const int bad = spec.body.Initialize(std::move(mesh), material);
    if (bad >= 0) {
      checks.Fail(mesh_path,
                  "element " + std::to_string(bad) +
                      " is inverted or degenerate (its Jacobian determinant is not positive); check the node "
                      "order (node = i + 3 j + 9 k over the reference grid) and coordinates");
    }

    ReadClamps(checks, e, path, rigid_bodies, &spec);
    ReadLoads(checks, e, path, &spec);
    out.push_back(std::move(spec));
  }
  return out;
}
}  // namespace cosim::smooth
