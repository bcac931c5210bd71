#pragma once
// The contact process's model: point masses ("contact nodes") and the planes they may touch,
// built and validated from a scenario (how they are integrated, numerics.nonsmooth, is the
// integrator's: integrator/moreau_jean_settings.h). Immutable once built; the integrator's
// changing state lives in its workspace (see integrator/moreau_jean.h), the frames of obstacles
// driven by the coordinator of a coupled run in ContactData, the step's input (the integrator's
// checkpoints do not hold it).
#include <Eigen/Core>
#include <array>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "interface/scenario/scenario_file.h"
#include "interface/scenario/time_function.h"

namespace cosim::nonsmooth {

using interface::TimeFunction;

struct ContactNode {
  std::string name;
  double mass = 1.0;                                         // [kg]
  Eigen::Vector3d position = Eigen::Vector3d::Zero();        // initial [m]
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();        // initial [m/s]
  Eigen::Vector3d constant_force = Eigen::Vector3d::Zero();  // [N], gravity included
  std::array<TimeFunction, 3> force_function;                // [N], time-prescribed
  bool has_time_force = false;
  // Linear spring-damper to an anchor point (zero rest length).
  Eigen::Vector3d anchor = Eigen::Vector3d::Zero();
  double stiffness = 0.0;  // [N/m]
  double damping = 0.0;    // [N s/m]
};

// The plane {x : n(t)·(x − p(t)) >= 0}: a reference point moving with constant velocity and
// a normal rotating about a fixed axis by a prescribed angle.
// The frame of a smooth body an obstacle is attached to, sent by the coordinator of a coupled
// run (proto/coupling.proto, Frame) at the step's start (accepted) and end (the iterate), and
// interpolated in between: origin and velocities linearly, rotation by slerp.
struct BodyFrame {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero(), velocity = Eigen::Vector3d::Zero();
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // body → global
};
// The step's life of the frame: StartAt (the Hello), then per step BeginStep (the last accepted
// end becomes the start), SetEnd for each try (a coupling iteration's input), and RejectStep if
// the coordinator rejects it; an accepted step's end is where the next begins.
struct DrivenFrame {
  double t0 = 0.0, t1 = 0.0;
  BodyFrame start, end;  // at t0 (last accepted) and t1 (the step's end, this iteration)
  // The plane's point, normal and tangent in the body frame (fixed at the Hello).
  Eigen::Vector3d point_body = Eigen::Vector3d::Zero(), normal_body = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d tangent_body = Eigen::Vector3d::UnitX();
  BodyFrame At(double t) const;

  // The body's frame at time t as both ends (a run's start).
  void StartAt(const BodyFrame& frame, double t) {
    start = end = frame;
    t0 = t1 = t;
  }
  // Fixes the plane (point p, normal n, tangent, global) in the start frame: p = o + R p_body.
  void FixPlane(const Eigen::Vector3d& point, const Eigen::Vector3d& normal, const Eigen::Vector3d& tangent) {
    point_body = start.rotation.transpose() * (point - start.origin);
    normal_body = start.rotation.transpose() * normal;
    tangent_body = start.rotation.transpose() * tangent;
  }
  void BeginStep(double t, double h) {
    start = end;
    t0 = t;
    t1 = t + h;
  }
  void SetEnd(const BodyFrame& frame) { end = frame; }
  void RejectStep() { end = start; }
};

// What changes in a contact model during a run besides the nodes' state: the frames of the
// obstacles attached to smooth bodies (Obstacle::driven indexes them), set by the coupling
// server at the Hello, each StepBegin and each Reactions. They are the step's input, as the
// external forces are, not its state: the integrators' checkpoints do not hold them, so that
// restoring a step's start leaves the frames of the try under way as they were given.
struct ContactData {
  std::vector<DrivenFrame> frames;
};

// The plane {x : n(t)·(x − p(t)) >= 0}: fixed, moving with a prescribed rigid motion (a
// constant velocity plus a rotation angle about an axis through p), or attached to a body of
// the smooth model in a coupled run (`driven`: the frames come from the coordinator, in the
// run's ContactData; the integrator reads them through the same functions).
struct Obstacle {
  std::string name;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();     // p(0)
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();   // n(0), unit
  Eigen::Vector3d tangent = Eigen::Vector3d::UnitX();  // t(0), unit, ⟂ n(0): friction facets start here
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  Eigen::Vector3d rotation_axis = Eigen::Vector3d::UnitZ();  // unit
  TimeFunction rotation_angle;                               // [rad]
  bool moving = false;
  // Attached to a smooth body: its index in ContactData::frames (−1: not driven) and the body.
  int driven = -1;
  std::string driven_body;

  // At time t; `data` holds the driven frames (unused for the other obstacles).
  Eigen::Vector3d PointAt(double t, const ContactData& data) const;
  Eigen::Vector3d NormalAt(double t, const ContactData& data) const;
  Eigen::Vector3d TangentAt(double t, const ContactData& data) const;
  // Velocity of the plane's material point at x: V + ω × (x − p(t)).
  Eigen::Vector3d VelocityAt(double t, const Eigen::Vector3d& x, const ContactData& data) const;
  // Signed distance of x from the plane at time t.
  double Gap(double t, const Eigen::Vector3d& x, const ContactData& data) const {
    return NormalAt(t, data).dot(x - PointAt(t, data));
  }
  // Part of the gap rate that comes from the plane's motion: dg/dt = n·ẋ + GapRateBias(t, x).
  double GapRateBias(double t, const Eigen::Vector3d& x, const ContactData& data) const;
};

// Linear spring-damper between two nodes: f₁ = −k (x₁ − x₂ − r₀) − c (ẋ₁ − ẋ₂), f₂ = −f₁.
struct NodeSpring {
  std::string name;
  int node1 = 0;
  int node2 = 0;
  double stiffness = 0.0;  // [N/m]
  double damping = 0.0;    // [N s/m]
  Eigen::Vector3d rest_offset = Eigen::Vector3d::Zero();
};

// Nodes linked (directly or not) by node springs: their dynamics couple, so their contacts
// interact in the LCP. A node without springs is a group of its own.
struct NodeGroup {
  std::vector<int> nodes;     // model node indices
  std::vector<int> contacts;  // model contact indices of these nodes
};

struct Contact {
  std::string name;  // "node/obstacle"
  int node = 0;
  int obstacle = 0;
  double restitution = 0.0;  // Newton's e in [0, 1]
  double friction = 0.0;     // Coulomb μ >= 0
};

enum class ProbeKind { kPosition, kVelocity, kGap, kImpulse, kKineticEnergy, kPotentialEnergy, kTotalEnergy };

struct Probe {
  std::string name;
  ProbeKind kind = ProbeKind::kPosition;
  int index = -1;     // node or contact; -1 = the whole process
  int component = 0;  // 0, 1, 2 = x, y, z; 3 = norm
};

struct ContactModel {
  std::vector<ContactNode> nodes;
  std::vector<Obstacle> obstacles;
  std::vector<Contact> contacts;
  std::vector<NodeSpring> springs;
  std::vector<NodeGroup> groups;
  std::vector<int> node_group;  // group of each node
  std::vector<int> node_slot;   // position of each node within its group
  std::vector<Probe> probes;
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();
  int driven_frames = 0;  // obstacles attached to smooth bodies (ContactData::frames' size)
};

// Builds and validates the contact model of a scenario. Throws InputError naming the field.
// Energies of the nodes at (q, v): kinetic, and potential of gravity, anchor springs and (for
// node < 0, the whole process) node springs. node < 0: all nodes.
double KineticEnergy(const ContactModel& model, const Eigen::VectorXd& v, int node);
double PotentialEnergy(const ContactModel& model, const Eigen::VectorXd& q, int node);

// `only_nodes` (a contact process of a coupled run with several): build these contact nodes
// only; the others, their contacts and probes belong to other processes and are skipped.
ContactModel BuildContactModel(const interface::ScenarioFile& file, const std::set<std::string>* only_nodes = nullptr);

}  // namespace cosim::nonsmooth
