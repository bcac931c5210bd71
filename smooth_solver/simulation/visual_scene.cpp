#include "smooth_solver/simulation/visual_scene.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <set>
#include <vector>

#include "smooth_solver/constraints/bilinear_constraints.h"

namespace cosim::smooth {

using interface::VisualFrame;

const std::array<int, 27>& VtkHex27Order() {
  // VTK's parametric positions of its 27 nodes (vtkTriQuadraticHexahedron), as −1, 0, 1.
  static const std::array<int, 27> order = [] {
    constexpr int kPositions[27][3] = {
        {-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1}, {-1, -1, 1}, {1, -1, 1}, {1, 1, 1}, {-1, 1, 1},  // corners
        {0, -1, -1},  {1, 0, -1},  {0, 1, -1}, {-1, 0, -1}, {0, -1, 1},  {1, 0, 1},  {0, 1, 1}, {-1, 0, 1},  // edges
        {-1, -1, 0},  {1, -1, 0},  {1, 1, 0},  {-1, 1, 0},                                                   // edges
        {-1, 0, 0},   {1, 0, 0},   {0, -1, 0}, {0, 1, 0},   {0, 0, -1},  {0, 0, 1},                          // faces
        {0, 0, 0}};                                                                                          // centre
    std::array<int, 27> o{};
    for (int k = 0; k < 27; ++k)
      o[static_cast<size_t>(k)] = (kPositions[k][0] + 1) + 3 * (kPositions[k][1] + 1) + 9 * (kPositions[k][2] + 1);
    return o;
  }();
  return order;
}

namespace {

// A rigid body: its origin and axes, lines to the points attached to it, and its box.
void DrawRigidBody(const MultibodyModel& model, const Eigen::VectorXd& q, size_t b,
                   const std::vector<Eigen::Vector3d>& attached, const VisualSettings& settings, VisualFrame* frame) {
  const int base = kCoordinatesPerBody * static_cast<int>(b);
  const Eigen::Vector3d x = q.segment<3>(base);
  const Eigen::Matrix3d axes = BodyAxes(q, static_cast<int>(b));
  double size = 0.0;
  for (const auto& s : attached) size = std::max(size, s.norm());
  const double length = settings.axis_length > 0.0 ? settings.axis_length : size > 0.0 ? 0.25 * size : 0.1;
  const int origin = frame->AddPoint(x);
  for (int k = 0; k < 3; ++k) {
    frame->AddCell(VisualFrame::kLine, {origin, frame->AddPoint(x + length * axes.col(k))},
                   VisualFrame::Kind::kBodyAxis, static_cast<int>(b));
  }
  for (const auto& s : attached) {
    if (s.norm() == 0.0) continue;
    frame->AddCell(VisualFrame::kLine, {origin, frame->AddPoint(x + axes * s)}, VisualFrame::Kind::kBodyShape,
                   static_cast<int>(b));
  }
  // Its shape: the box in its own axes around its origin and those points, each side at least
  // a tenth of its size (0.1 of the axis length for a body with no such points).
  Eigen::Vector3d lo = Eigen::Vector3d::Zero(), hi = Eigen::Vector3d::Zero();
  for (const auto& s : attached) {
    lo = lo.cwiseMin(s);
    hi = hi.cwiseMax(s);
  }
  const double thinnest = 0.05 * (size > 0.0 ? size : length);
  const Eigen::Vector3d mid = 0.5 * (lo + hi), half = (0.5 * (hi - lo)).cwiseMax(thinnest);
  std::vector<int> box;
  for (const auto& c :
       {Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(1, -1, -1), Eigen::Vector3d(1, 1, -1), Eigen::Vector3d(-1, 1, -1),
        Eigen::Vector3d(-1, -1, 1), Eigen::Vector3d(1, -1, 1), Eigen::Vector3d(1, 1, 1), Eigen::Vector3d(-1, 1, 1)}) {
    box.push_back(frame->AddPoint(x + axes * (mid + half.cwiseProduct(c))));  // VTK_HEXAHEDRON's corner order
  }
  frame->AddCell(VisualFrame::kHexahedron, box, VisualFrame::Kind::kBodyShape, static_cast<int>(b));
  frame->Name(VisualFrame::Kind::kBodyAxis, static_cast<int>(b), model.bodies[b].name);
}

// Rigid bodies (not the beams' nodes, drawn with their beams), with the points that joints and
// ties attach to them.
void DrawRigidBodies(const MultibodyModel& model, const Eigen::VectorXd& q, const VisualSettings& settings,
                     VisualFrame* frame) {
  std::set<int> beam_nodes;
  for (const auto& beam : model.beams) beam_nodes.insert(beam.node_bodies.begin(), beam.node_bodies.end());
  std::vector<std::vector<Eigen::Vector3d>> attached(model.bodies.size());  // body-frame points
  auto attach = [&](int body, const Eigen::Vector3d& local) {
    if (body >= 0) attached[static_cast<size_t>(body)].push_back(local);
  };
  auto local_of = [&](int body, const Eigen::Vector3d& global) {  // a point of the initial pose, in body axes
    const RigidBody& b = model.bodies[static_cast<size_t>(body)];
    return Eigen::Vector3d(b.orientation.toRotationMatrix().transpose() * (global - b.position));
  };
  for (const Joint& j : model.joints) {
    for (int side = 0; side < 2; ++side) {
      const int body = side == 0 ? j.body1 : j.body2;
      if (body < 0) continue;
      attach(body, j.body_points ? (side == 0 ? j.point1 : j.point2) : local_of(body, j.point));
    }
  }
  for (const InterfacePointSpec& p : model.interface_points) attach(p.body, p.point);
  for (size_t b = 0; b < model.bodies.size(); ++b) {
    if (beam_nodes.count(static_cast<int>(b)) == 0) DrawRigidBody(model, q, b, attached[b], settings, frame);
  }
}

}  // namespace

void DrawHex27Body(const ElasticBody& body, const std::string& name, int index,
                   const Eigen::Ref<const Eigen::Matrix3Xd>& x, VisualFrame* frame) {
  const int first = frame->points();
  for (int a = 0; a < body.node_count(); ++a) frame->AddPoint(x.col(a), x.col(a) - body.mesh().nodes.col(a));
  const std::vector<double> stress = body.VonMisesStress(x);
  std::vector<int> cell(27);
  for (size_t el = 0; el < body.mesh().elements.size(); ++el) {
    for (int k = 0; k < 27; ++k) {
      cell[static_cast<size_t>(k)] =
          first + body.mesh().elements[el][static_cast<size_t>(VtkHex27Order()[static_cast<size_t>(k)])];
    }
    frame->AddCell(VisualFrame::kTriQuadraticHexahedron, cell, VisualFrame::Kind::kSolid, index, 0, stress[el]);
  }
  frame->Name(VisualFrame::Kind::kSolid, index, name);
}

namespace {

void DrawBeams(const MultibodyModel& model, const Eigen::VectorXd& q, VisualFrame* frame) {
  // Beams: lines between the nodes; each node's section frame as a line along its chordwise
  // director d2 (a fourteenth of the span: about a rotor blade's chord) and a quarter as long
  // along its flapwise d3; quads between neighbouring chord lines (the blade as a ribbon).
  for (size_t m = 0; m < model.beams.size(); ++m) {
    const BeamModel& beam = model.beams[m];
    const double half_chord = (beam.span_end - beam.span_start) / 28.0;
    std::vector<int> axis, lead, trail, flap;
    for (int node : beam.node_bodies) {
      const int base = kCoordinatesPerBody * node;
      const Eigen::Vector3d x = q.segment<3>(base), d2 = q.segment<3>(base + 6).normalized();
      axis.push_back(frame->AddPoint(x));
      lead.push_back(frame->AddPoint(x + half_chord * d2));
      trail.push_back(frame->AddPoint(x - half_chord * d2));
      flap.push_back(frame->AddPoint(x + 0.5 * half_chord * q.segment<3>(base + 9).normalized()));  // d3
    }
    // (Line segments rather than one poly-line: meshio 7 drops VTK's poly-lines.)
    for (size_t i = 0; i + 1 < axis.size(); ++i) {
      frame->AddCell(VisualFrame::kLine, {axis[i], axis[i + 1]}, VisualFrame::Kind::kBeamAxis, static_cast<int>(m));
    }
    for (size_t i = 0; i < axis.size(); ++i) {
      frame->AddCell(VisualFrame::kLine, {lead[i], trail[i]}, VisualFrame::Kind::kBeamSection, static_cast<int>(m));
      frame->AddCell(VisualFrame::kLine, {axis[i], flap[i]}, VisualFrame::Kind::kBeamSection, static_cast<int>(m));
      if (i + 1 < axis.size()) {
        frame->AddCell(VisualFrame::kQuad, {lead[i], lead[i + 1], trail[i + 1], trail[i]},
                       VisualFrame::Kind::kBeamSection, static_cast<int>(m));
      }
    }
    frame->Name(VisualFrame::Kind::kBeamAxis, static_cast<int>(m), beam.name);
  }
}

void DrawHex27Bodies(const MultibodySystem& system, const Eigen::VectorXd& q, VisualFrame* frame) {
  for (size_t e = 0; e < system.elastic.size(); ++e) {
    const ElasticBody& body = system.elastic[e]->body;
    const Eigen::Map<const Eigen::Matrix3Xd> x(q.data() + system.elastic_offset[e], 3, body.node_count());
    DrawHex27Body(body, system.elastic[e]->name, static_cast<int>(e), x, frame);
  }
}

void DrawContacts(const MultibodyModel& model, const Eigen::VectorXd& q, VisualFrame* frame) {
  // Continuous contacts (monolithic scenes): the body point as a vertex, its plane as a square
  // around the point's projection (side 4 × their in-plane distance, at least 0.2 m); both in
  // contact while the gap is closed. (Joint stops are angles: nothing to draw.)
  int contact = 0;
  for (const ForceSpec& f : model.forces) {
    if (f.kind != ForceSpec::Kind::kContact) continue;
    const Eigen::Vector3d p = LinearVector::Point(f.body1, f.point1).Value(q);
    const Eigen::Vector3d c = LinearVector::Point(f.plane_body, f.plane_point).Value(q);
    const Eigen::Vector3d n = LinearVector::Direction(f.plane_body, f.plane_normal).Value(q).normalized();
    const int closed = n.dot(p - c) <= 0.0 ? 1 : 0;
    frame->AddCell(VisualFrame::kVertex, {frame->AddPoint(p)}, VisualFrame::Kind::kContactNode, contact, closed);
    const Eigen::Vector3d d = p - c, t1 = n.unitOrthogonal(), t2 = n.cross(t1);
    const double half = std::max(0.1, 2.0 * (d - d.dot(n) * n).norm());
    frame->AddSquare(c, t1, t2, half, VisualFrame::Kind::kObstacle, contact, closed);
    frame->Name(VisualFrame::Kind::kContactNode, contact, f.name);
    frame->Name(VisualFrame::Kind::kObstacle, contact, f.name);
    ++contact;
  }
}

void DrawTies(const MultibodySystem& system, const SystemData& data, const Eigen::VectorXd& q, VisualFrame* frame) {
  // Ties: the body point and the node the peer imposes (3 imposed coordinates per point).
  const auto& imposed = data.imposed;
  for (size_t k = 0; k < system.interface_points.size(); ++k) {
    if (imposed.size() < 3 * (k + 1)) break;
    const Eigen::Vector3d node(imposed[3 * k].value, imposed[3 * k + 1].value, imposed[3 * k + 2].value);
    frame->AddCell(VisualFrame::kLine,
                   {frame->AddPoint(system.interface_points[k].point.Value(q)), frame->AddPoint(node)},
                   VisualFrame::Kind::kTie, static_cast<int>(k));
    frame->Name(VisualFrame::Kind::kTie, static_cast<int>(k), system.interface_points[k].contact_node);
  }
}

}  // namespace

void DrawScene(const MultibodyModel& model, const MultibodySystem& system, const SystemData& data,
               const Eigen::VectorXd& q, const VisualSettings& settings, VisualFrame* frame) {
  DrawRigidBodies(model, q, settings, frame);
  DrawBeams(model, q, frame);
  DrawHex27Bodies(system, q, frame);
  DrawContacts(model, q, frame);
  DrawTies(system, data, q, frame);
}
}  // namespace cosim::smooth
