#pragma once
// The smooth solver's model: rigid bodies, joints and force elements, built and validated
// from a scenario. Immutable once built: the validated description the integrators (CGα, IDA)
// integrate, the elastic bodies beside it.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <string>
#include <vector>

#include "interface/scenario/scenario_file.h"
#include "interface/scenario/time_function.h"
#include "smooth_solver/aero/air_loads.h"
#include "smooth_solver/beam/beam_model.h"
#include "smooth_solver/forces/force_elements.h"

namespace cosim::smooth {

struct RigidBody {
  std::string name;
  double mass = 0.0;                                   // [kg]
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();   // about the centre of mass, body frame
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // centre of mass
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();
};

enum class JointType { kRevolute, kPrismatic, kSpherical, kUniversal, kFixed };

struct Joint {
  std::string name;
  JointType type = JointType::kRevolute;
  int body1 = -1;  // -1 = ground
  int body2 = -1;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();  // global, initial configuration
  bool body_points = false;                         // point1/point2 given in body frames
  Eigen::Vector3d point1 = Eigen::Vector3d::Zero();
  Eigen::Vector3d point2 = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d axis2 = Eigen::Vector3d::UnitX();
  bool driven = false;
  bool drive_is_rate = false;  // speed or angular speed rather than displacement or angle
  interface::TimeFunction drive;
  bool locked = false;
  bool lock_at_closure = false;  // the lock holds the closed loop's value, not the given pose's
  double release_time = 0.0;
  double initial_coordinate = 0.0;  // the coordinate of the initial poses [rad or m]
};

// A force element as given in the scenario (model.forces).
struct ForceSpec {
  enum class Kind { kLoad, kSpring, kJointSpring, kContact, kJointStop };
  Kind kind = Kind::kLoad;
  std::string name;
  int body1 = -1, body2 = -1;  // load: body1; spring: both (−1 = ground)
  Eigen::Vector3d point1 = Eigen::Vector3d::Zero(), point2 = Eigen::Vector3d::Zero();
  int joint = -1;  // joint spring
  double stiffness = 0.0, damping = 0.0, rest = 0.0;
  bool has_rest = false;
  std::array<interface::TimeFunction, 3> force, torque;
  bool has_torque = false;
  // Continuous contact: body1's point1 against a plane (point, unit normal) fixed in space
  // (plane_body = −1) or in body plane_body (both in that body's frame). Joint stop: joint.
  int plane_body = -1;
  Eigen::Vector3d plane_point = Eigen::Vector3d::Zero(), plane_normal = Eigen::Vector3d::UnitZ();
  HuntCrossleyLaw law;
  bool has_lower = false, has_upper = false;
  double lower = 0.0, upper = 0.0;  // [rad]
};

// A coupling interface node on the smooth side: the material point `point` (body frame) of
// rigid body `body`, which must follow the contact node `contact_node` of a contact process
// (coupling.interface_nodes).
struct InterfacePointSpec {
  std::string contact_node;
  int body = -1;                        // rigid body, or −1 for a node of an elastic body:
  std::string elastic_body;             // its name (resolved with the elastic bodies),
  std::string elastic_point;            // the node as given (index or face centre),
  int elastic = -1, elastic_node = -1;  // and once resolved: elastic body index and node
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  double regularization = 0.0;  // c of Φ − cλ = 0 [m/N]
};

struct MultibodyModel {
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();
  std::vector<RigidBody> bodies;
  std::vector<Joint> joints;
  std::vector<int> hold_joints;  // joints whose coordinate and speed the initial state keeps
  // The bodies of the moving bases (model.moving_bases: their links and the base), which start
  // at rest: a shaft on a deck turns against them as against the ground.
  std::vector<int> base_bodies;
  std::vector<ForceSpec> forces;
  std::vector<InterfacePointSpec> interface_points;
  // Beams: their nodes are bodies (with no mass of their own) among `bodies`.
  std::vector<BeamModel> beams;
  // Air loads (model.air); empty: none.
  AeroModel aero;

  // The rigid bodies' names, by body index.
  std::vector<std::string> BodyNames() const {
    std::vector<std::string> names;
    names.reserve(bodies.size());
    for (const RigidBody& b : bodies) names.push_back(b.name);
    return names;
  }
};

// Throws InputError naming the field for every inconsistency it finds.
MultibodyModel BuildMultibodyModel(const interface::ScenarioFile& file);

}  // namespace cosim::smooth
