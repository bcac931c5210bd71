#include "smooth_solver/model/multibody_system.h"

#include <cmath>

#include "smooth_solver/elastic/elastic_force.h"

namespace cosim::smooth {

namespace {

// Rotation and position of a body in the initial configuration (ground: identity, origin).
struct Frame {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d x = Eigen::Vector3d::Zero();
};

Frame FrameOf(const MultibodyModel& model, int body) {
  Frame f;
  if (body >= 0) {
    f.R = model.bodies[static_cast<size_t>(body)].orientation.toRotationMatrix();
    f.x = model.bodies[static_cast<size_t>(body)].position;
  }
  return f;
}

// A material direction of `body` that points along the global `a` in the initial configuration.
LinearVector DirectionOf(int body, const Frame& f, const Eigen::Vector3d& a) {
  return LinearVector::Direction(body, body < 0 ? a : Eigen::Vector3d(f.R.transpose() * a));
}

// Unit vector perpendicular to a.
Eigen::Vector3d Perpendicular(const Eigen::Vector3d& a) {
  Eigen::Index least = 0;
  a.cwiseAbs().minCoeff(&least);
  const Eigen::Vector3d e = Eigen::Vector3d::Unit(least);
  return (e - e.dot(a) * a).normalized();
}

void AddDot(ScalarConstraint* c, const LinearVector& a, const LinearVector& b, DriveWeight w = {}) {
  c->terms.push_back({a, b, w});
}

}  // namespace

double MultibodySystem::JointCoordinate(int joint, const Eigen::VectorXd& q) const {
  const JointMeasure& m = joints[static_cast<size_t>(joint)];
  if (!m.rotational) return m.separation.Value(q).dot(m.axis1.Value(q));
  const Eigen::Vector3d b2 = m.b2.Value(q);
  return std::atan2(b2.dot(m.c1.Value(q)), b2.dot(m.b1.Value(q)));
}

double MultibodySystem::JointRate(int joint, const Eigen::VectorXd& q, const Eigen::VectorXd& qdot) const {
  const JointMeasure& m = joints[static_cast<size_t>(joint)];
  if (!m.rotational) {
    return m.separation.Rate(qdot).dot(m.axis1.Value(q)) + m.separation.Value(q).dot(m.axis1.Rate(qdot));
  }
  // θ = atan2(y, x): θ̇ = (x ẏ − y ẋ)/(x² + y²).
  const Eigen::Vector3d b2 = m.b2.Value(q), b2d = m.b2.Rate(qdot);
  const Eigen::Vector3d b1 = m.b1.Value(q), b1d = m.b1.Rate(qdot), c1 = m.c1.Value(q), c1d = m.c1.Rate(qdot);
  const double x = b2.dot(b1), y = b2.dot(c1);
  const double xd = b2d.dot(b1) + b2.dot(b1d), yd = b2d.dot(c1) + b2.dot(c1d);
  return (x * yd - y * xd) / (x * x + y * y);
}

void MultibodySystem::Force(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, const SystemData& data,
                            Eigen::Ref<Eigen::VectorXd> f, bool include_elastic) const {
  f = constant_force;
  for (const auto& element : forces) {
    if (include_elastic || !element->IsElastic()) element->AddForce(q, qdot, t, data, f);
  }
}

void MultibodySystem::AddForceTangent(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t,
                                      const SystemData& data, double stiffness_scale, double damping_scale,
                                      SparseSink* sink, bool include_elastic) const {
  for (const auto& element : forces) {
    if (include_elastic || !element->IsElastic()) {
      element->AddTangent(q, qdot, t, data, stiffness_scale, damping_scale, sink);
    }
  }
}

void MultibodySystem::AcceptStep(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t,
                                 SystemData* data) const {
  for (const auto& element : forces) element->AcceptStep(q, qdot, t, data);
}

double MultibodySystem::TimeToContact(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot) const {
  double t = std::numeric_limits<double>::infinity();
  for (const auto& element : forces) t = std::min(t, element->TimeToContact(q, qdot));
  return t;
}

void MultibodySystem::ForcePattern(SparseSink* sink) const {
  for (const auto& element : forces) element->Pattern(sink);
}

void MultibodySystem::ClampReaction(int e, const Eigen::VectorXd& q, const Eigen::VectorXd& lambda,
                                    Eigen::Vector3d* force, Eigen::Vector3d* moment) const {
  const auto& rows = elastic_clamp_rows[static_cast<size_t>(e)];
  const ElasticBody& body = elastic[static_cast<size_t>(e)]->body;
  const int o = elastic_offset[static_cast<size_t>(e)];
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& [row, node] : rows) centroid += body.mesh().nodes.col(node);
  if (!rows.empty()) centroid /= static_cast<double>(rows.size());
  force->setZero();
  moment->setZero();
  for (const auto& [row, node] : rows) {
    const Eigen::Vector3d R = -lambda.segment<3>(row);
    *force += R;
    *moment += (Eigen::Vector3d(q.segment<3>(o + 3 * node)) - centroid).cross(R);
  }
}

double MultibodySystem::PotentialEnergy(const Eigen::VectorXd& q) const {
  double e = -constant_force.dot(q);  // gravity
  for (const auto& element : forces) e += element->PotentialEnergy(q);
  return e;
}

Eigen::Vector3d MultibodySystem::JointReactionForce(int joint, const Eigen::VectorXd& q, const Eigen::VectorXd& lambda,
                                                    double t, const SystemData& data) const {
  const JointMeasure& m = joints[static_cast<size_t>(joint)];
  // Φ = p1 − p2: the generalised constraint force −Φ_qᵀλ on body2's position is +λ.
  if (m.has_point_rows) return lambda.segment<3>(m.first_row);
  // Otherwise (prismatic): −Φ_qᵀλ of the joint's rows on body2's position (body1 exerts it), or
  // minus that on body1's when body2 is the ground.
  Eigen::VectorXd selected = Eigen::VectorXd::Zero(lambda.size());
  selected.segment(m.first_row, m.row_count) = lambda.segment(m.first_row, m.row_count);
  Eigen::VectorXd g = Eigen::VectorXd::Zero(coordinates);
  constraints.AddJacobianTransposeTimes(data.imposed, q, t, selected, g);
  return m.body2 >= 0 ? Eigen::Vector3d(-g.segment<3>(kCoordinatesPerBody * m.body2))
                      : Eigen::Vector3d(g.segment<3>(kCoordinatesPerBody * m.body1));
}

Eigen::Vector3d MultibodySystem::JointReactionMoment(int joint, const Eigen::VectorXd& q, const Eigen::VectorXd& lambda,
                                                     double t, const SystemData& data) const {
  const JointMeasure& m = joints[static_cast<size_t>(joint)];
  Eigen::VectorXd selected = Eigen::VectorXd::Zero(lambda.size());
  const int first = m.first_row + (m.has_point_rows ? 3 : 0);
  selected.segment(first, m.first_row + m.row_count - first) = lambda.segment(first, m.first_row + m.row_count - first);
  Eigen::VectorXd g = Eigen::VectorXd::Zero(coordinates);
  constraints.AddJacobianTransposeTimes(data.imposed, q, t, selected, g);  // Φ_qᵀ λ; the force is −g
  // A generalised force g_k on the axis e_k of a body is the couple Σ_k e_k × g_k.
  const int body = m.body2 >= 0 ? m.body2 : m.body1;
  const int o = kCoordinatesPerBody * body;
  Eigen::Vector3d moment = Eigen::Vector3d::Zero();
  for (int k = 0; k < 3; ++k) {
    moment -= Eigen::Vector3d(q.segment<3>(o + 3 + 3 * k)).cross(Eigen::Vector3d(g.segment<3>(o + 3 + 3 * k)));
  }
  return m.body2 >= 0 ? moment : Eigen::Vector3d(-moment);
}

namespace {

// A new slot for a contact law's onset speed in the system's data.
size_t NewImpactSlot(MultibodySystem* sys) { return static_cast<size_t>(sys->impact_slots++); }

// Rigid bodies: the coordinates' initial values, the mass (kinetic energy in natural
// coordinates), gravity, and six rigidity rows per body.
void AddRigidBodies(const MultibodyModel& model, MultibodySystem* sys, std::vector<Eigen::Triplet<double>>* mass) {
  const int nb = static_cast<int>(model.bodies.size());
  for (int b = 0; b < nb; ++b) {
    const RigidBody& body = model.bodies[static_cast<size_t>(b)];
    const int o = kCoordinatesPerBody * b;
    const Eigen::Matrix3d R = body.orientation.toRotationMatrix();
    sys->q0.segment<3>(o) = body.position;
    sys->qdot0.segment<3>(o) = body.velocity;
    for (int k = 0; k < 3; ++k) {
      sys->q0.segment<3>(o + 3 + 3 * k) = R.col(k);
      sys->qdot0.segment<3>(o + 3 + 3 * k) = body.angular_velocity.cross(Eigen::Vector3d(R.col(k)));
    }
    // Kinetic energy ½ m ẋ² + ½ Σ_ij J̄_ij u̇_i·u̇_j, J̄ = ½ tr(I) E − I.
    const Eigen::Matrix3d J = 0.5 * body.inertia.trace() * Eigen::Matrix3d::Identity() - body.inertia;
    for (int k = 0; k < 3; ++k) {
      mass->emplace_back(o + k, o + k, body.mass);
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
          if (J(i, j) != 0.0) mass->emplace_back(o + 3 + 3 * i + k, o + 3 + 3 * j + k, J(i, j));
        }
      }
    }
    sys->constant_force.segment<3>(o) = body.mass * model.gravity;
    // Rigidity: the body axes stay orthonormal (6 constraints per body).
    const LinearVector u = LinearVector::Direction(b, Eigen::Vector3d::UnitX());
    const LinearVector v = LinearVector::Direction(b, Eigen::Vector3d::UnitY());
    const LinearVector w = LinearVector::Direction(b, Eigen::Vector3d::UnitZ());
    const std::pair<const LinearVector*, const LinearVector*> pairs[6] = {{&u, &u}, {&v, &v}, {&w, &w},
                                                                          {&u, &v}, {&u, &w}, {&v, &w}};
    const char* names[6] = {"u.u", "v.v", "w.w", "u.v", "u.w", "v.w"};
    for (int k = 0; k < 6; ++k) {
      ScalarConstraint c;
      c.name = body.name + ".rigid_" + names[k];
      AddDot(&c, *pairs[k].first, *pairs[k].second);
      c.constant = k < 3 ? -1.0 : 0.0;
      sys->constraints.constraints.push_back(c);
    }
  }
}

void AddElasticBodies(const MultibodyModel& model, MultibodySystem* sys, std::vector<Eigen::Triplet<double>>* mass) {
  // Elastic bodies: node positions as coordinates, consistent mass, gravity as M g per node.
  for (size_t e = 0; e < sys->elastic.size(); ++e) {
    const ElasticBody& body = sys->elastic[e]->body;
    const int o = sys->elastic_offset[e];
    const Eigen::SparseMatrix<double> Me = body.MassMatrix();
    for (int k = 0; k < Me.outerSize(); ++k) {
      for (Eigen::SparseMatrix<double>::InnerIterator it(Me, k); it; ++it) {
        mass->emplace_back(o + static_cast<int>(it.row()), o + static_cast<int>(it.col()), it.value());
      }
    }
    for (int a = 0; a < body.node_count(); ++a) {
      sys->q0.segment<3>(o + 3 * a) = body.mesh().nodes.col(a);
      sys->qdot0.segment<3>(o + 3 * a).setZero();
    }
    Eigen::VectorXd g(3 * body.node_count());
    for (int a = 0; a < body.node_count(); ++a) g.segment<3>(3 * a) = model.gravity;
    sys->constant_force.segment(o, g.size()) = Me * g;
    auto force = std::make_unique<ElasticForce>(&body, o, sys->elastic[e]->strain_damping);
    sys->elastic_forces.push_back(force.get());
    sys->forces.push_back(std::move(force));
    if (sys->elastic[e]->retardation_time > 0.0) {
      sys->forces.push_back(std::make_unique<ElasticDamping>(&body, o, sys->elastic[e]->retardation_time));
    }
    for (const auto& load : sys->elastic[e]->loads) {
      sys->forces.push_back(std::make_unique<NodalForce>(o + 3 * load.node, body.mesh().nodes.col(load.node),
                                                         load.force, load.factor, load.time_varying));
    }
    // Clamps: node = the material point of the rigid body (or the ground point) it sits at.
    sys->elastic_clamp_rows.emplace_back();
    for (const auto& clamp : sys->elastic[e]->clamps) {
      const Frame f = FrameOf(model, clamp.rigid_body);
      for (int node : clamp.nodes) {
        const Eigen::Vector3d X = body.mesh().nodes.col(node);
        LinearVector at_node;
        at_node.terms.push_back({o + 3 * node, 1.0});
        const LinearVector at_body = clamp.rigid_body < 0
                                         ? LinearVector::Constant(X)
                                         : LinearVector::Point(clamp.rigid_body, f.R.transpose() * (X - f.x));
        sys->elastic_clamp_rows.back().emplace_back(sys->constraints.size(), node);
        sys->constraints.vector_triples.push_back(sys->constraints.size());
        for (int k = 0; k < 3; ++k) {
          ScalarConstraint c;
          c.name = sys->elastic[e]->name + ".clamp_node_" + std::to_string(node);
          AddDot(&c, at_node - at_body, LinearVector::Constant(Eigen::Vector3d::Unit(k)));
          sys->constraints.constraints.push_back(c);
        }
      }
    }
  }
}

void AddBeams(const MultibodyModel& model, MultibodySystem* sys, std::vector<Eigen::Triplet<double>>* mass) {
  // Beams: each element's constant mass over its nodes' coordinates (slot x, d1, d2, d3 of each
  // node, ⊗ I3), gravity as M g on the positions, and the internal force element.
  for (const BeamModel& beam : model.beams) {
    const int nn = beam.nodes_per_element;
    for (const BeamElement& el : beam.elements) {
      const Eigen::MatrixXd Ms = BeamElementMass(nn, el.s0, el.length, beam.table, beam.RotaryFloor(el));
      for (int I = 0; I < nn; ++I) {
        for (int sI = 0; sI < 4; ++sI) {
          const int row = kCoordinatesPerBody * el.node[static_cast<size_t>(I)] + 3 * sI;
          double gravity_weight = 0.0;  // Σ_J M(I sI, J x): the node slot's share of m g
          for (int J = 0; J < nn; ++J) {
            const int col0 = kCoordinatesPerBody * el.node[static_cast<size_t>(J)];
            gravity_weight += Ms(4 * I + sI, 4 * J);
            for (int sJ = 0; sJ < 4; ++sJ) {
              const double v = Ms(4 * I + sI, 4 * J + sJ);
              if (v == 0.0) continue;
              for (int k = 0; k < 3; ++k) mass->emplace_back(row + k, col0 + 3 * sJ + k, v);
            }
          }
          sys->constant_force.segment<3>(row) += gravity_weight * model.gravity;
        }
      }
    }
    auto force = std::make_unique<BeamForce>(beam.name, nn, beam.elements, beam.retardation);
    sys->beam_forces.push_back(force.get());
    sys->forces.push_back(std::move(force));
  }
}

// A driven joint's drive row, a locked joint's lock row.
void AddDriveAndLock(const Joint& j, const JointMeasure& measure, MultibodySystem* sys) {
  ConstraintSet& cs = sys->constraints;
  if (j.driven) {
    // Revolute: sin θd (b2·b1) − cos θd (b2·c1) = sin(θd − θ) = 0. Prismatic: (p2 − p1)·a1 − θd = 0.
    const int d = static_cast<int>(cs.drives.size());
    cs.drives.push_back(Drive{j.drive, j.drive_is_rate});
    ScalarConstraint drive;
    drive.name = j.name + ".drive";
    if (j.type == JointType::kRevolute) {
      AddDot(&drive, measure.b2, measure.b1, DriveWeight{DriveWeight::Kind::kSin, 1.0, d});
      AddDot(&drive, measure.b2, measure.c1, DriveWeight{DriveWeight::Kind::kCos, -1.0, d});
    } else {
      AddDot(&drive, measure.separation, measure.axis1);
      drive.constant = -1.0;
      drive.constant_weight = DriveWeight{DriveWeight::Kind::kValue, 1.0, d};
    }
    cs.constraints.push_back(drive);
  }
  if (j.locked) {
    // Locked: the coordinate keeps its initial value until release_time (+∞: for good).
    ScalarConstraint lock;
    lock.name = j.name + ".lock";
    if (j.type == JointType::kRevolute) {
      AddDot(&lock, measure.b2, measure.c1);  // sin θ = 0
    } else {
      AddDot(&lock, measure.separation, measure.axis1);
      lock.constant = -measure.separation.Value(sys->q0).dot(measure.axis1.Value(sys->q0));
    }
    lock.release_time = j.release_time;
    lock.set_by_closure = j.lock_at_closure;
    cs.constraints.push_back(lock);
  }
}

// A joint's rows and its measure (coordinate, reaction).
void AddJoint(const MultibodyModel& model, const Joint& j, MultibodySystem* sys) {
  const Frame f1 = FrameOf(model, j.body1), f2 = FrameOf(model, j.body2);
  ConstraintSet& cs = sys->constraints;
  JointMeasure measure;
  measure.first_row = cs.size();
  auto add = [&](const std::string& what, const LinearVector& a, const LinearVector& b, double constant = 0.0) {
    ScalarConstraint c;
    c.name = j.name + "." + what;
    AddDot(&c, a, b);
    c.constant = constant;
    cs.constraints.push_back(c);
  };
  // Joint points on each body (body frame), or from the global point in the given poses.
  const Eigen::Vector3d s1 = j.body_points ? j.point1 : Eigen::Vector3d(f1.R.transpose() * (j.point - f1.x));
  const Eigen::Vector3d s2 = j.body_points ? j.point2 : Eigen::Vector3d(f2.R.transpose() * (j.point - f2.x));
  const LinearVector p1 = j.body1 < 0 ? LinearVector::Constant(s1) : LinearVector::Point(j.body1, s1);
  const LinearVector p2 = j.body2 < 0 ? LinearVector::Constant(s2) : LinearVector::Point(j.body2, s2);
  const Eigen::Vector3d a = j.axis, b = Perpendicular(a), c = a.cross(b);
  const LinearVector a1 = DirectionOf(j.body1, f1, a), b1 = DirectionOf(j.body1, f1, b),
                     c1 = DirectionOf(j.body1, f1, c);
  const LinearVector a2 = DirectionOf(j.body2, f2, a), b2 = DirectionOf(j.body2, f2, b);
  const bool point_rows = j.type != JointType::kPrismatic;
  if (point_rows) {
    // Coincidence of the joint's points: λ of these rows is the force body1 exerts on body2
    // (with the sign convention Φ = p1 − p2).
    const char* axes[3] = {"x", "y", "z"};
    cs.vector_triples.push_back(cs.size());
    for (int k = 0; k < 3; ++k)
      add(std::string("point_") + axes[k], p1 - p2, LinearVector::Constant(Eigen::Vector3d::Unit(k)));
  }
  measure.has_point_rows = point_rows;
  switch (j.type) {
    case JointType::kRevolute:
      add("axis_b", a2, b1);
      add("axis_c", a2, c1);
      break;
    case JointType::kUniversal: {
      const LinearVector axis2 = DirectionOf(j.body2, f2, j.axis2);
      add("cross", a1, axis2, -a.dot(j.axis2));
      break;
    }
    case JointType::kFixed:
      add("axis_b", a2, b1);
      add("axis_c", a2, c1);
      add("twist", b2, c1);
      break;
    case JointType::kPrismatic:
      add("axis_b", a2, b1);
      add("axis_c", a2, c1);
      add("twist", b2, c1);
      add("slide_b", p2 - p1, b1);
      add("slide_c", p2 - p1, c1);
      break;
    case JointType::kSpherical:
      break;
  }
  measure.rotational = j.type != JointType::kPrismatic;
  measure.b1 = b1;
  measure.c1 = c1;
  measure.b2 = b2;
  measure.separation = p2 - p1;
  measure.axis1 = a1;
  AddDriveAndLock(j, measure, sys);
  measure.row_count = cs.size() - measure.first_row;
  measure.body1 = j.body1;
  measure.body2 = j.body2;
  sys->joints.push_back(measure);
}

void AddForceElements(const MultibodyModel& model, MultibodySystem* sys) {
  for (const ForceSpec& f : model.forces) {
    sys->contact_laws.emplace_back();
    switch (f.kind) {
      case ForceSpec::Kind::kLoad:
        sys->forces.push_back(std::make_unique<AppliedLoad>(f.body1, f.point1, f.force, f.torque, f.has_torque));
        break;
      case ForceSpec::Kind::kSpring: {
        const LinearVector p1 = LinearVector::Point(f.body1, f.point1), p2 = LinearVector::Point(f.body2, f.point2);
        const double rest = f.has_rest ? f.rest : (p2 - p1).Value(sys->q0).norm();
        sys->forces.push_back(std::make_unique<PointSpring>(p1, p2, f.stiffness, f.damping, rest));
        break;
      }
      case ForceSpec::Kind::kJointSpring: {
        const JointMeasure& m = sys->joints[static_cast<size_t>(f.joint)];
        // Coordinates are measured from the initial poses; a given rest is in the joint's own.
        const double rest =
            f.has_rest ? f.rest - model.joints[static_cast<size_t>(f.joint)].initial_coordinate : f.rest;
        if (m.rotational) {
          sys->forces.push_back(std::make_unique<CoordinateSpring>(m.b1, m.c1, m.b2, f.stiffness, f.damping, rest));
        } else {
          // The prismatic coordinate is measured from the given pose.
          const double s0 = m.separation.Value(sys->q0).dot(m.axis1.Value(sys->q0));
          sys->forces.push_back(
              std::make_unique<CoordinateSpring>(m.separation, m.axis1, f.stiffness, f.damping, s0 + rest));
        }
        break;
      }
      case ForceSpec::Kind::kContact: {
        // Signed gap g = (p − c)·n of body1's point against the plane (θ0 = 0, g >= 0 allowed).
        CoordinateSpring gap(LinearVector::Point(f.body1, f.point1) - LinearVector::Point(f.plane_body, f.plane_point),
                             LinearVector::Direction(f.plane_body, f.plane_normal), 0.0, 0.0, 0.0);
        auto contact = std::make_unique<UnilateralContact>(std::move(gap), 0.0, 1.0, f.law, NewImpactSlot(sys));
        sys->contact_laws.back().push_back(contact.get());
        sys->forces.push_back(std::move(contact));
        break;
      }
      case ForceSpec::Kind::kJointStop: {
        const JointMeasure& m = sys->joints[static_cast<size_t>(f.joint)];
        const double offset =
            model.joints[static_cast<size_t>(f.joint)].initial_coordinate;  // stops in the joint's own
        for (int side : {1, -1}) {
          if (side > 0 ? !f.has_lower : !f.has_upper) continue;
          auto stop = std::make_unique<UnilateralContact>(CoordinateSpring(m.b1, m.c1, m.b2, 0.0, 0.0, 0.0),
                                                          (side > 0 ? f.lower : f.upper) - offset, side, f.law,
                                                          NewImpactSlot(sys));
          sys->contact_laws.back().push_back(stop.get());
          sys->forces.push_back(std::move(stop));
        }
        break;
      }
    }
  }
}

void AddInterfacePoints(const MultibodyModel& model, MultibodySystem* sys) {
  // Coupling interface nodes: e_j · p(q) − x_j = 0 with x_j imposed (drive weight −1 on the
  // constant), and the regularisation c on their rows.
  if (!model.interface_points.empty()) {
    ConstraintSet& cs = sys->constraints;
    cs.compliance.resize(cs.constraints.size(), 0.0);
    for (size_t k = 0; k < model.interface_points.size(); ++k) {
      const InterfacePointSpec& spec = model.interface_points[k];
      InterfacePoint ip;
      ip.contact_node = spec.contact_node;
      ip.first_row = cs.size();
      ip.elastic = spec.elastic >= 0;
      ip.body = spec.elastic >= 0 ? -1 : spec.body;
      ip.regularization = spec.regularization;
      for (const BeamModel& beam : model.beams) {  // a beam's node is a body of the model too
        for (int b : beam.node_bodies) ip.elastic = ip.elastic || (spec.elastic < 0 && b == spec.body);
      }
      if (spec.elastic >= 0) {  // an elastic body's node: its three coordinates
        ip.point.terms.push_back({sys->elastic_offset[static_cast<size_t>(spec.elastic)] + 3 * spec.elastic_node, 1.0});
      } else {
        ip.point = LinearVector::Point(spec.body, spec.point);
      }
      cs.vector_triples.push_back(cs.size());
      for (int j = 0; j < 3; ++j) {
        const int d = static_cast<int>(cs.drives.size());
        Drive drive;
        drive.imposed = static_cast<int>(3 * k) + j;  // (data.imposed, read at each evaluation)
        cs.drives.push_back(drive);
        ScalarConstraint row;
        row.name = "coupling." + spec.contact_node + "." + std::string(1, "xyz"[j]);
        AddDot(&row, ip.point, LinearVector::Constant(Eigen::Vector3d::Unit(j)));
        row.constant = 1.0;
        row.constant_weight = DriveWeight{DriveWeight::Kind::kValue, -1.0, d};
        cs.constraints.push_back(row);
        cs.compliance.push_back(spec.regularization);
      }
      sys->interface_points.push_back(ip);
    }
  }
}

// The rows that hold joints at their given pose while the initial state is made consistent.
void AddHolds(const MultibodyModel& model, MultibodySystem* sys) {
  for (int h : model.hold_joints) {
    const JointMeasure& m = sys->joints[static_cast<size_t>(h)];
    ScalarConstraint c;
    c.name = model.joints[static_cast<size_t>(h)].name + ".hold";
    if (m.rotational) {
      AddDot(&c, m.b2, m.c1);  // sin θ = 0 at the given pose
    } else {
      AddDot(&c, m.separation, m.axis1);
      c.constant = -(m.separation.Value(sys->q0).dot(m.axis1.Value(sys->q0)));
    }
    sys->holds.constraints.push_back(c);
  }
}

}  // namespace

MultibodySystem BuildMultibodySystem(const MultibodyModel& model, std::vector<ElasticBodySpec>* elastic) {
  MultibodySystem sys;
  int n = kCoordinatesPerBody * static_cast<int>(model.bodies.size());
  if (elastic != nullptr) {
    for (auto& spec : *elastic) {
      sys.elastic_offset.push_back(n);
      n += 3 * spec.body.node_count();
      sys.elastic.push_back(std::make_unique<ElasticBodySpec>(std::move(spec)));
    }
  }
  sys.coordinates = n;
  sys.q0.resize(n);
  sys.qdot0.resize(n);
  sys.constant_force = Eigen::VectorXd::Zero(n);
  std::vector<Eigen::Triplet<double>> mass;
  AddRigidBodies(model, &sys, &mass);
  AddElasticBodies(model, &sys, &mass);
  AddBeams(model, &sys, &mass);
  for (const BeamModel& beam : model.beams) sys.beam_node_bodies.push_back(beam.node_bodies);
  sys.mass.resize(n, n);
  sys.mass.setFromTriplets(mass.begin(), mass.end());
  if (!model.aero.empty()) {
    auto air = std::make_unique<AirLoads>(model.aero, sys.elastic_offset);
    sys.air_loads = air.get();
    sys.forces.push_back(std::move(air));
  }
  for (const Joint& j : model.joints) AddJoint(model, j, &sys);
  AddForceElements(model, &sys);
  AddInterfacePoints(model, &sys);
  AddHolds(model, &sys);
  return sys;
}

SystemData MakeData(const MultibodySystem& system) {
  SystemData data;
  data.imposed.resize(3 * system.interface_points.size());  // (never resized again)
  for (size_t k = 0; k < system.interface_points.size(); ++k) {
    const Eigen::Vector3d at = system.interface_points[k].point.Value(system.q0);
    // Until the peer says otherwise: where the point is, moving as the initial guess moves it. A
    // rate of 0 held the point still while the initial velocities were made consistent: a beam
    // node tied to a stop pad on a spinning hingeless rotor started at rest while its beam turned
    // (accelerations of 1e6 m/s², and the first coupled step failed at every step length;
    // generated hingeless rotors started at speed).
    const Eigen::Vector3d rate = system.interface_points[k].point.Rate(system.qdot0);
    for (int j = 0; j < 3; ++j) {
      data.imposed[3 * k + static_cast<size_t>(j)].value = at(j);
      data.imposed[3 * k + static_cast<size_t>(j)].rate = rate(j);
    }
  }
  data.interface_compliance.assign(system.interface_points.size(), Eigen::Matrix3d::Zero());
  data.impact_speed.assign(static_cast<size_t>(system.impact_slots), 0.0);
  if (system.air_loads != nullptr) data.rotors.assign(system.air_loads->rotor_count(), RotorInflowState{});
  return data;
}

}  // namespace cosim::smooth
