#include "smooth_solver/model/multibody_model.h"

#include <Eigen/Eigenvalues>
#include <array>
#include <cmath>
#include <limits>
#include <set>

#include "interface/scenario/checks.h"
#include "smooth_solver/model/aero_input.h"
#include "smooth_solver/model/beam_input.h"

namespace cosim::smooth {

using interface::Checks;
using interface::ElementPath;
using interface::FormatNumber;
using interface::NameTable;
namespace sc = cosim::scenario;

namespace {

// Eq. (8)'s parameters, validated.
HuntCrossleyLaw ContactLaw(const Checks& checks, const std::string& path, bool has,
                           const sc::ForceElement::HuntCrossley& l) {
  checks.Require(path, has, "law { stiffness: K restitution: e }");
  HuntCrossleyLaw law;
  law.stiffness = checks.Positive(path + ".stiffness", l.has_stiffness(), l.stiffness(), "N/m^n or N m/rad^n");
  law.exponent = checks.Positive(path + ".exponent", true, l.exponent(), "dimensionless");
  checks.Require(path + ".restitution", l.has_restitution(), "Newton's restitution e in (0, 1]");
  if (!(l.restitution() > 0.0 && l.restitution() <= 1.0)) {
    checks.Fail(path + ".restitution",
                "must be in (0, 1] (the law divides by e), got " + FormatNumber(l.restitution()));
  }
  // As given, or the law's e whose own rebound is the given one (so that K → ∞ converges to
  // the Newton law with that e, as the nonsmooth model has it).
  law.restitution =
      l.effective_restitution() ? interface::LawRestitution(l.restitution(), law.exponent) : l.restitution();
  law.speed_threshold = checks.Positive(path + ".speed_threshold", true, l.speed_threshold(), "m/s or rad/s");
  return law;
}

Eigen::Matrix3d Inertia(const Checks& checks, const std::string& path,
                        const google::protobuf::RepeatedField<double>& v) {
  Eigen::Matrix3d J = Eigen::Matrix3d::Zero();
  if (v.size() == 3) {
    J.diagonal() << v.Get(0), v.Get(1), v.Get(2);
  } else if (v.size() == 6) {
    J << v.Get(0), v.Get(3), v.Get(4),  //
        v.Get(3), v.Get(1), v.Get(5),   //
        v.Get(4), v.Get(5), v.Get(2);
  } else {
    checks.Fail(path, "expected [Ixx, Iyy, Izz] or [Ixx, Iyy, Izz, Ixy, Ixz, Iyz] in kg m^2, got " +
                          std::to_string(v.size()) + " values");
  }
  const Eigen::Vector3d moments = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(J).eigenvalues();  // ascending
  if (!(moments.minCoeff() > 0.0)) {
    checks.Fail(path, "must be positive definite; its smallest principal moment is " +
                          FormatNumber(moments.minCoeff()) + " kg m^2");
  }
  // A real body's principal moments obey I1 + I2 >= I3: the second moments of its mass
  // distribution, J̄ = ½ tr(I) E − I (the natural-coordinate mass matrix's), are ≥ 0. A flat body
  // (a disc, a plate: I1 + I2 = I3) has one zero second moment — its mass matrix is singular
  // along that axis, but the rigidity constraints fix that axis from the other two and the
  // constrained problem is regular. Two zero second moments (all mass on a line: I3 = 0, caught
  // above) leave the rotation about the line without inertia. Round-off of the sum is allowed.
  const double round_off = 64.0 * std::numeric_limits<double>::epsilon() * moments.sum();
  if (moments(0) + moments(1) < moments(2) - round_off) {
    checks.Fail(path, "principal moments " + FormatNumber(moments(0)) + ", " + FormatNumber(moments(1)) + ", " +
                          FormatNumber(moments(2)) +
                          " kg m^2 break the triangle inequality I1 + I2 >= I3 that every real body obeys");
  }
  return J;
}

// model.moving_bases: each a chain ground → surge → sway → heave (prismatic x, y, z) → yaw →
// pitch → roll (revolute z, y', x'') → the base body, every joint driven by its function (zero if
// absent), all at the base's point with the global axes at zero motion (proto/scenario/model.proto,
// MovingBase). The bodies first (the user's joints name the base), the joints after theirs.
struct BaseLink {
  const char* suffix;  // the link's body and joint: NAME.suffix; the last link's body is NAME
  JointType type;
  Eigen::Vector3d axis;
};
const std::array<BaseLink, 6> kBaseLinks{{{"surge", JointType::kPrismatic, Eigen::Vector3d::UnitX()},
                                          {"sway", JointType::kPrismatic, Eigen::Vector3d::UnitY()},
                                          {"heave", JointType::kPrismatic, Eigen::Vector3d::UnitZ()},
                                          {"yaw", JointType::kRevolute, Eigen::Vector3d::UnitZ()},
                                          {"pitch", JointType::kRevolute, Eigen::Vector3d::UnitY()},
                                          {"roll", JointType::kRevolute, Eigen::Vector3d::UnitX()}}};

// The bodies of the moving bases, declared into `names`; returns the index of each base's first.
std::vector<int> AddMovingBaseBodies(const Checks& checks, NameTable* names, MultibodyModel* model) {
  const sc::Model& m = checks.file().proto().model();
  std::vector<int> first;
  for (int i = 0; i < m.moving_bases_size(); ++i) {
    const sc::MovingBase& b = m.moving_bases(i);
    const std::string path = ElementPath("model.moving_bases", i);
    if (b.name() == "ground") checks.Fail(path + ".name", "'ground' is the fixed frame; choose another name");
    const std::string name = checks.Name(path + ".name", b.has_name(), b.name());
    const Eigen::Vector3d point = checks.Vector3(path + ".point", b.point(), Eigen::Vector3d::Zero());
    first.push_back(static_cast<int>(model->bodies.size()));
    for (size_t k = 0; k < kBaseLinks.size(); ++k) {
      RigidBody body;
      const bool last = k + 1 == kBaseLinks.size();
      body.name = names->Declare(path + ".name", true, last ? name : name + "." + kBaseLinks[k].suffix);
      // The links' motion is prescribed: their masses only scale the drives' reactions.
      body.mass = last ? checks.Positive(path + ".mass", true, b.mass(), "kg") : 1.0;
      body.inertia = last && b.inertia_size() > 0 ? Inertia(checks, path + ".inertia", b.inertia())
                                                  : Eigen::Matrix3d::Identity() * (last ? 1000.0 : 1.0);
      body.position = point;
      model->base_bodies.push_back(static_cast<int>(model->bodies.size()));
      model->bodies.push_back(body);
    }
  }
  return first;
}

void AddMovingBaseJoints(const Checks& checks, const std::vector<int>& first, NameTable* names, MultibodyModel* model) {
  const sc::Model& m = checks.file().proto().model();
  for (int i = 0; i < m.moving_bases_size(); ++i) {
    const sc::MovingBase& b = m.moving_bases(i);
    const std::string path = ElementPath("model.moving_bases", i);
    const std::array<std::pair<bool, const sc::TimeFunction*>, 6> functions{{{b.has_surge(), &b.surge()},
                                                                             {b.has_sway(), &b.sway()},
                                                                             {b.has_heave(), &b.heave()},
                                                                             {b.has_yaw(), &b.yaw()},
                                                                             {b.has_pitch(), &b.pitch()},
                                                                             {b.has_roll(), &b.roll()}}};
    for (size_t k = 0; k < kBaseLinks.size(); ++k) {
      Joint joint;
      joint.name = names->Declare(path + ".name", true, b.name() + "." + kBaseLinks[k].suffix);
      joint.type = kBaseLinks[k].type;
      joint.body1 = k == 0 ? -1 : first[static_cast<size_t>(i)] + static_cast<int>(k) - 1;
      joint.body2 = first[static_cast<size_t>(i)] + static_cast<int>(k);
      joint.point = model->bodies[static_cast<size_t>(joint.body2)].position;
      joint.axis = kBaseLinks[k].axis;
      joint.driven = true;
      if (functions[k].first) {
        const std::string where = path + "." + kBaseLinks[k].suffix;
        joint.drive = interface::TimeFunction::Build(checks, where, *functions[k].second);
        // The scene is drawn at zero motion, at rest: a base displaced or moving at the start
        // would carry its passengers only as far as the initial projections move them.
        const double t0 = checks.file().proto().numerics().start_time();
        const double value = joint.drive.Value(t0), rate = joint.drive.Derivative(t0);
        const char* unit = joint.type == JointType::kPrismatic ? " m" : " rad";
        if (std::abs(value) > 1e-12 || std::abs(rate) > 1e-12) {
          checks.Fail(where, "is " + interface::FormatNumber(value) + unit + " at " + interface::FormatNumber(rate) +
                                 unit + "/s at the start (t = " + interface::FormatNumber(t0) +
                                 " s); the scene is drawn with the base at zero motion and at rest: start each "
                                 "motion there (a harmonic with a ramp_time, or a constant cancelling its value)");
        }
      }
      model->joints.push_back(joint);
    }
  }
}

}  // namespace

namespace {

// A body by name, or -1 for "ground".
int FindBody(const Checks& checks, const NameTable& body_names, const std::string& path, bool has,
             const std::string& name) {
  checks.Require(path, has, "a body name or \"ground\"");
  return name == "ground" ? -1 : body_names.Find(path, name);
}

void AddBodies(const Checks& checks, const sc::Model& m, NameTable* body_names, MultibodyModel* model) {
  for (int i = 0; i < m.bodies_size(); ++i) {
    const sc::RigidBody& b = m.bodies(i);
    const std::string path = ElementPath("model.bodies", i);
    RigidBody body;
    if (b.name() == "ground") checks.Fail(path + ".name", "'ground' is the fixed frame; choose another name");
    body.name = body_names->Declare(path + ".name", b.has_name(), b.name());
    body.mass = checks.Positive(path + ".mass", b.has_mass(), b.mass(), "kg");
    body.inertia = Inertia(checks, path + ".inertia", b.inertia());
    body.position = checks.Vector3(path + ".position", b.position(), Eigen::Vector3d::Zero());
    const Eigen::Vector3d rv = checks.Vector3(path + ".rotation", b.rotation(), Eigen::Vector3d::Zero());
    body.orientation = rv.norm() == 0.0 ? Eigen::Quaterniond::Identity()  // (a NaN stays a NaN)
                                        : Eigen::Quaterniond(Eigen::AngleAxisd(rv.norm(), rv / rv.norm()));
    body.velocity = checks.Vector3(path + ".velocity", b.velocity(), Eigen::Vector3d::Zero());
    body.angular_velocity = checks.Vector3(path + ".angular_velocity", b.angular_velocity(), Eigen::Vector3d::Zero());
    model->bodies.push_back(body);
  }
}

// joint.drive: what it drives (an angle or a length, or their rate) and its time function.
void ReadDrive(const Checks& checks, const std::string& path, const sc::Drive& d, Joint* joint_out) {
  Joint& joint = *joint_out;
  const bool rotational = joint.type == JointType::kRevolute;
  const bool translational = joint.type == JointType::kPrismatic;
  if (!rotational && !translational) {
    checks.Fail(path, "only revolute and prismatic joints have a coordinate to drive");
  }
  const bool angle = d.quantity() == sc::Drive::ANGLE || d.quantity() == sc::Drive::ANGULAR_SPEED;
  const bool length = d.quantity() == sc::Drive::DISPLACEMENT || d.quantity() == sc::Drive::SPEED;
  if (!angle && !length) {
    checks.Fail(path + ".quantity", "expected ANGLE, ANGULAR_SPEED, DISPLACEMENT or SPEED");
  }
  if (rotational && !angle) {
    checks.Fail(path + ".quantity", "a revolute joint's coordinate is an angle [rad]; " +
                                        sc::Drive::Quantity_Name(d.quantity()) +
                                        " is a length unit; use ANGLE or ANGULAR_SPEED");
  }
  if (translational && !length) {
    checks.Fail(path + ".quantity", "a prismatic joint's coordinate is a length [m]; " +
                                        sc::Drive::Quantity_Name(d.quantity()) +
                                        " is an angle unit; use DISPLACEMENT or SPEED");
  }
  checks.Require(path + ".function", d.has_function(), "a time function");
  joint.driven = true;
  joint.drive_is_rate = d.quantity() == sc::Drive::ANGULAR_SPEED || d.quantity() == sc::Drive::SPEED;
  joint.drive = interface::TimeFunction::Build(checks, path + ".function", d.function());
}

// The scenario's joint types (the message listing them comes from this table).
constexpr std::pair<sc::Joint::Type, JointType> kJointTypes[] = {
    {sc::Joint::REVOLUTE, JointType::kRevolute},   {sc::Joint::PRISMATIC, JointType::kPrismatic},
    {sc::Joint::SPHERICAL, JointType::kSpherical}, {sc::Joint::UNIVERSAL, JointType::kUniversal},
    {sc::Joint::FIXED, JointType::kFixed},
};

JointType ReadJointType(const Checks& checks, const std::string& path, sc::Joint::Type type) {
  std::string expected;
  for (size_t i = 0; i < std::size(kJointTypes); ++i) {
    if (kJointTypes[i].first == type) return kJointTypes[i].second;
    expected += (i == 0                            ? ""
                 : i + 1 == std::size(kJointTypes) ? " or "
                                                   : ", ") +
                sc::Joint::Type_Name(kJointTypes[i].first);
  }
  checks.Fail(path, "expected " + expected);
  return JointType::kRevolute;  // (not reached: Fail throws)
}

Joint ReadJoint(const Checks& checks, const NameTable& body_names, NameTable* joint_names, const sc::Joint& j,
                const std::string& path) {
  Joint joint;
  joint.name = joint_names->Declare(path + ".name", j.has_name(), j.name());
  joint.type = ReadJointType(checks, path + ".type", j.type());
  joint.body1 = FindBody(checks, body_names, path + ".body1", j.has_body1(), j.body1());
  joint.body2 = FindBody(checks, body_names, path + ".body2", j.has_body2(), j.body2());
  if (joint.body1 == joint.body2) {
    checks.Fail(path + ".body2", "joins '" + j.body2() + "' to itself; a joint needs two different bodies");
  }
  if (j.point1_size() > 0 || j.point2_size() > 0) {
    joint.body_points = true;
    joint.point1 = checks.Vector3(path + ".point1", j.point1(), std::nullopt);
    joint.point2 = checks.Vector3(path + ".point2", j.point2(), std::nullopt);
  } else {
    joint.point = checks.Vector3(path + ".point", j.point(), std::nullopt);
  }
  const bool needs_axis =
      joint.type == JointType::kRevolute || joint.type == JointType::kPrismatic || joint.type == JointType::kUniversal;
  if (needs_axis) joint.axis = checks.Direction(path + ".axis", j.axis());
  if (joint.type == JointType::kUniversal) {
    joint.axis2 = checks.Direction(path + ".axis2", j.axis2());
    if (std::abs(joint.axis.dot(joint.axis2)) > 1.0 - 1e-9) {
      checks.Fail(path + ".axis2", "is parallel to axis; a universal joint needs two distinct axes");
    }
  }
  if (j.has_drive()) ReadDrive(checks, path + ".drive", j.drive(), &joint);
  joint.locked = j.locked();
  joint.lock_at_closure = j.lock_at_closure();
  if (j.lock_at_closure() && !j.locked()) {
    checks.Fail(path + ".lock_at_closure", "given for a joint that is not locked; add `locked: true`");
  }
  joint.initial_coordinate = j.initial_coordinate();
  if (j.has_initial_coordinate() && j.has_drive()) {
    checks.Fail(path + ".initial_coordinate", "a driven joint's coordinate is its drive's; remove one of them");
  }
  if (j.has_initial_coordinate() && joint.type != JointType::kRevolute && joint.type != JointType::kPrismatic) {
    checks.Fail(path + ".initial_coordinate", "only revolute and prismatic joints have one coordinate");
  }
  joint.release_time = std::numeric_limits<double>::infinity();
  if (j.has_release_time()) {
    if (!j.locked()) checks.Fail(path + ".release_time", "given for a joint that is not locked");
    if (!std::isfinite(j.release_time())) checks.Fail(path + ".release_time", "must be a finite time [s]");
    joint.release_time = j.release_time();
  }
  if (joint.locked) {
    if (joint.type != JointType::kRevolute && joint.type != JointType::kPrismatic) {
      checks.Fail(path + ".locked", "only revolute and prismatic joints (one coordinate) can be locked");
    }
    if (joint.driven) checks.Fail(path + ".locked", "a driven joint cannot also be locked");
  }
  return joint;
}

void ReadLoad(const Checks& checks, const NameTable& body_names, const sc::ForceElement& fe, const std::string& path,
              ForceSpec* spec) {
  const auto& l = fe.load();
  spec->kind = ForceSpec::Kind::kLoad;
  checks.Require(path + ".load.body", l.has_body(), "the name of a body");
  if (l.body() == "ground") checks.Fail(path + ".load.body", "a load on the ground does nothing; name a body");
  spec->body1 = body_names.Find(path + ".load.body", l.body());
  spec->point1 = checks.Vector3(path + ".load.point", l.point(), Eigen::Vector3d::Zero());
  for (const auto* list : {&l.force(), &l.torque()}) {
    const bool is_force = list == &l.force();
    const std::string lpath = path + (is_force ? ".load.force" : ".load.torque");
    if (list->empty()) continue;
    if (list->size() != 3) {
      checks.Fail(lpath, "expected 3 functions (x, y, z components), got " + std::to_string(list->size()));
    }
    for (int c = 0; c < 3; ++c) {
      (is_force ? spec->force : spec->torque)[static_cast<size_t>(c)] =
          interface::TimeFunction::Build(checks, ElementPath(lpath, c), list->Get(c));
    }
    if (!is_force) spec->has_torque = true;
  }
  if (l.force().empty() && l.torque().empty()) checks.Fail(path + ".load", "gives neither force nor torque");
}

void ReadSpring(const Checks& checks, const NameTable& body_names, const sc::ForceElement& fe, const std::string& path,
                ForceSpec* spec) {
  const auto& sp = fe.spring();
  spec->kind = ForceSpec::Kind::kSpring;
  spec->body1 = FindBody(checks, body_names, path + ".spring.body1", sp.has_body1(), sp.body1());
  spec->body2 = FindBody(checks, body_names, path + ".spring.body2", sp.has_body2(), sp.body2());
  spec->point1 = checks.Vector3(path + ".spring.point1", sp.point1(), Eigen::Vector3d::Zero());
  spec->point2 = checks.Vector3(path + ".spring.point2", sp.point2(), Eigen::Vector3d::Zero());
  checks.Require(path + ".spring.stiffness", sp.has_stiffness(), "a stiffness in N/m");
  spec->stiffness = checks.NonNegative(path + ".spring.stiffness", sp.stiffness(), "N/m");
  spec->damping = checks.NonNegative(path + ".spring.damping", sp.damping(), "N s/m");
  if (sp.has_rest_length()) {
    spec->rest = checks.NonNegative(path + ".spring.rest_length", sp.rest_length(), "m");
    spec->has_rest = true;
  }
}

void ReadJointSpring(const Checks& checks, const NameTable& joint_names, const MultibodyModel& model,
                     const sc::ForceElement& fe, const std::string& path, ForceSpec* spec) {
  const auto& js = fe.joint_spring();
  spec->kind = ForceSpec::Kind::kJointSpring;
  checks.Require(path + ".joint_spring.joint", js.has_joint(), "the name of a revolute or prismatic joint");
  spec->joint = joint_names.Find(path + ".joint_spring.joint", js.joint());
  const JointType type = model.joints[static_cast<size_t>(spec->joint)].type;
  if (type != JointType::kRevolute && type != JointType::kPrismatic) {
    checks.Fail(path + ".joint_spring.joint",
                "joint '" + js.joint() + "' has no single coordinate; only revolute and prismatic do");
  }
  const std::string unit = type == JointType::kRevolute ? "N m/rad" : "N/m";
  checks.Require(path + ".joint_spring.stiffness", js.has_stiffness(), "a stiffness in " + unit);
  spec->stiffness = checks.NonNegative(path + ".joint_spring.stiffness", js.stiffness(), unit);
  spec->damping = checks.NonNegative(path + ".joint_spring.damping", js.damping(),
                                     type == JointType::kRevolute ? "N m s/rad" : "N s/m");
  spec->rest = js.rest_value();
}

void ReadContinuousContact(const Checks& checks, const NameTable& body_names, const sc::Model& m,
                           const MultibodyModel& model, const sc::ForceElement& fe, const std::string& path,
                           ForceSpec* spec) {
  const auto& cc = fe.continuous_contact();
  spec->kind = ForceSpec::Kind::kContact;
  spec->body1 = FindBody(checks, body_names, path + ".continuous_contact.body", cc.has_body(), cc.body());
  if (spec->body1 < 0) checks.Fail(path + ".continuous_contact.body", "the contact point must be on a body");
  spec->point1 = checks.Vector3(path + ".continuous_contact.point", cc.point(), Eigen::Vector3d::Zero());
  checks.Require(path + ".continuous_contact.obstacle", cc.has_obstacle(), "the name of an obstacle (a plane)");
  int found = -1;
  for (int o = 0; o < m.obstacles_size(); ++o) {
    if (m.obstacles(o).name() == cc.obstacle()) found = o;
  }
  if (found < 0) checks.Fail(path + ".continuous_contact.obstacle", "no obstacle named '" + cc.obstacle() + "'");
  const sc::Obstacle& ob = m.obstacles(found);
  const std::string opath = ElementPath("model.obstacles", found);
  const Eigen::Vector3d point = checks.Vector3(opath + ".point", ob.point(), Eigen::Vector3d::Zero());
  const Eigen::Vector3d normal = checks.Vector3(opath + ".normal", ob.normal(), std::nullopt);
  if (!(normal.norm() > 0.0)) checks.Fail(opath + ".normal", "must be non-zero");
  spec->plane_point = point;
  spec->plane_normal = normal.normalized();
  if (ob.has_prescribed()) {
    checks.Fail(path + ".continuous_contact.obstacle",
                "obstacle '" + cc.obstacle() +
                    "' has a prescribed motion, which continuous contact does not "
                    "follow yet; attach it to a body or fix it");
  }
  if (ob.has_attached_to_body()) {
    spec->plane_body = body_names.Find(opath + ".attached_to_body", ob.attached_to_body());
    const RigidBody& b = model.bodies[static_cast<size_t>(spec->plane_body)];
    const Eigen::Matrix3d R = b.orientation.toRotationMatrix();
    spec->plane_point = R.transpose() * (point - b.position);  // in the body frame
    spec->plane_normal = R.transpose() * spec->plane_normal;
  }
  spec->law = ContactLaw(checks, path + ".continuous_contact.law", cc.has_law(), cc.law());
}

void ReadJointStop(const Checks& checks, const NameTable& joint_names, const MultibodyModel& model,
                   const sc::ForceElement& fe, const std::string& path, ForceSpec* spec) {
  const auto& js = fe.joint_stop();
  spec->kind = ForceSpec::Kind::kJointStop;
  checks.Require(path + ".joint_stop.joint", js.has_joint(), "the name of a revolute joint");
  spec->joint = joint_names.Find(path + ".joint_stop.joint", js.joint());
  if (model.joints[static_cast<size_t>(spec->joint)].type != JointType::kRevolute) {
    checks.Fail(path + ".joint_stop.joint", "joint '" + js.joint() + "' is not revolute");
  }
  spec->has_lower = js.has_lower();
  spec->has_upper = js.has_upper();
  spec->lower = js.lower();
  spec->upper = js.upper();
  if (!spec->has_lower && !spec->has_upper) checks.Fail(path + ".joint_stop", "give lower, upper or both [rad]");
  if (spec->has_lower && spec->has_upper && !(spec->lower < spec->upper)) {
    checks.Fail(path + ".joint_stop.upper",
                "must be above lower (" + FormatNumber(spec->lower) + " rad), got " + FormatNumber(spec->upper));
  }
  spec->law = ContactLaw(checks, path + ".joint_stop.law", js.has_law(), js.law());
}

void AddForces(const Checks& checks, const sc::Model& m, const NameTable& body_names, const NameTable& joint_names,
               MultibodyModel* model) {
  NameTable force_names(checks, "force element");
  for (int i = 0; i < m.forces_size(); ++i) {
    const sc::ForceElement& fe = m.forces(i);
    const std::string path = ElementPath("model.forces", i);
    ForceSpec spec;
    spec.name = force_names.Declare(path + ".name", fe.has_name(), fe.name());
    switch (fe.kind_case()) {
      case sc::ForceElement::kLoad:
        ReadLoad(checks, body_names, fe, path, &spec);
        break;
      case sc::ForceElement::kSpring:
        ReadSpring(checks, body_names, fe, path, &spec);
        break;
      case sc::ForceElement::kJointSpring:
        ReadJointSpring(checks, joint_names, *model, fe, path, &spec);
        break;
      case sc::ForceElement::kContinuousContact:
        ReadContinuousContact(checks, body_names, m, *model, fe, path, &spec);
        break;
      case sc::ForceElement::kJointStop:
        ReadJointStop(checks, joint_names, *model, fe, path, &spec);
        break;
      case sc::ForceElement::KIND_NOT_SET:
        checks.Fail(path, "empty force element; give load { ... }, spring { ... } or joint_spring { ... }");
    }
    model->forces.push_back(spec);
  }
}

void AddHoldJoints(const Checks& checks, const sc::Model& m, const NameTable& joint_names, MultibodyModel* model) {
  const auto& hold = m.initial_conditions().hold_joints();
  for (int i = 0; i < hold.size(); ++i) {
    const std::string path = ElementPath("model.initial_conditions.hold_joints", i);
    const int j = joint_names.Find(path, hold.Get(i));
    const JointType type = model->joints[static_cast<size_t>(j)].type;
    if (type != JointType::kRevolute && type != JointType::kPrismatic) {
      checks.Fail(path, "joint '" + hold.Get(i) + "' has no single coordinate to hold; only revolute and prismatic do");
    }
    model->hold_joints.push_back(j);
  }
}

void AddInterfaceNodes(const Checks& checks, const interface::ScenarioFile& file, const NameTable& body_names,
                       MultibodyModel* model) {
  const sc::Model& m = file.proto().model();
  // Coupling interface nodes: a contact node of the scenario tied to a rigid body's point.
  std::set<std::string> contact_nodes;
  for (const auto& node : m.contact_nodes()) contact_nodes.insert(node.name());
  std::set<std::string> tied;
  const auto& interface_nodes = file.proto().coupling().interface_nodes();
  for (int i = 0; i < interface_nodes.size(); ++i) {
    const auto& in = interface_nodes.Get(i);
    const std::string path = ElementPath("coupling.interface_nodes", i);
    InterfacePointSpec spec;
    checks.Require(path + ".contact_node", in.has_contact_node(), "the name of a contact node");
    if (contact_nodes.count(in.contact_node()) == 0) {
      std::string known;
      for (const auto& name : contact_nodes) known += (known.empty() ? "" : ", ") + name;
      checks.Fail(path + ".contact_node",
                  "no contact node named '" + in.contact_node() + "'" + (known.empty() ? "" : "; known: " + known));
    }
    if (!tied.insert(in.contact_node()).second) {
      checks.Fail(path + ".contact_node", "contact node '" + in.contact_node() + "' is tied to the smooth model twice");
    }
    spec.contact_node = in.contact_node();
    checks.Require(path + ".body", in.has_body(), "the name of a rigid or elastic body");
    bool elastic = false;
    for (const auto& e : file.proto().model().elastic_bodies()) elastic = elastic || e.name() == in.body();
    if (elastic) {
      checks.Require(path + ".node", in.has_node(),
                     "the elastic body's node (0-based index, tip_centre or root_centre)");
      if (in.point_size() != 0) checks.Fail(path + ".point", "an elastic body's point is a node: give `node` instead");
      spec.elastic_body = in.body();
      spec.elastic_point = in.node();
    } else {
      spec.body = body_names.Find(path + ".body", in.body());
      if (in.has_node())
        checks.Fail(path + ".node", "'" + in.body() + "' is a rigid body: give `point` (body frame offset)");
      spec.point = checks.Vector3(path + ".point", in.point(), Eigen::Vector3d::Zero());
    }
    spec.regularization = checks.NonNegative(path + ".regularization", in.regularization(), "m/N");
    model->interface_points.push_back(spec);
  }
}

}  // namespace

MultibodyModel BuildMultibodyModel(const interface::ScenarioFile& file) {
  const Checks checks(file);
  const sc::Model& m = file.proto().model();
  MultibodyModel model;
  model.gravity = checks.Vector3("model.gravity", m.gravity(), Eigen::Vector3d::Zero());
  NameTable body_names(checks, "body");
  AddBodies(checks, m, &body_names, &model);
  const std::vector<int> first_base_body = AddMovingBaseBodies(checks, &body_names, &model);
  AddBeams(checks, &body_names, &model);
  NameTable joint_names(checks, "joint");
  for (int i = 0; i < m.joints_size(); ++i) {
    model.joints.push_back(ReadJoint(checks, body_names, &joint_names, m.joints(i), ElementPath("model.joints", i)));
  }
  AddMovingBaseJoints(checks, first_base_body, &joint_names, &model);
  AddBeamClamps(checks, body_names, &joint_names, &model);
  AddAero(checks, body_names, &model);
  AddForces(checks, m, body_names, joint_names, &model);
  AddHoldJoints(checks, m, joint_names, &model);
  AddInterfaceNodes(checks, file, body_names, &model);
  return model;
}

}  // namespace cosim::smooth
