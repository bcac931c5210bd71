#pragma once
// The equations of motion of a MultibodyModel in natural coordinates:
//   M q̈ + Φ_qᵀ λ = f(q, q̇, t),   Φ(q, t) = 0,
// with a constant mass matrix M (so CGα needs no inertia Jacobians). Each body's 12
// coordinates are [x, u, v, w]; its kinetic energy ½ m ẋ² + ½ Σ_ij J̄_ij u̇_i·u̇_j uses the
// second moments J̄ = ½ tr(I) E − I of its inertia tensor I about the centre of mass.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <memory>
#include <string>
#include <vector>

#include "smooth_solver/aero/air_loads.h"
#include "smooth_solver/beam/beam.h"
#include "smooth_solver/constraints/bilinear_constraints.h"
#include "smooth_solver/data/system_data.h"
#include "smooth_solver/elastic/elastic_force.h"
#include "smooth_solver/elastic/elastic_model.h"
#include "smooth_solver/forces/force_elements.h"
#include "smooth_solver/model/multibody_model.h"

namespace cosim::smooth {

// What a probe needs to measure a joint: its coordinate and its reaction.
struct JointMeasure {
  int first_row = 0;  // first constraint row of the joint (its point coincidence rows
                      // come first when it has them)
  bool has_point_rows = false;
  int row_count = 0;  // rows of the joint, its drive included
  int body1 = -1, body2 = -1;
  // Revolute: angle of b2 from b1 towards c1 about the axis. Prismatic: (p2 − p1)·a1.
  LinearVector b1, c1, b2;
  LinearVector separation, axis1;
  bool rotational = true;
};

// A coupling interface node: three coincidence rows e_j · p(q) − x_j = 0 (rotor-sailing paper,
// Eq. (6)) between a body's material point p and the contact node's position x imposed by the
// peer. The multipliers of those rows are the force the smooth model exerts on the node.
struct InterfacePoint {
  std::string contact_node;
  int first_row = 0;            // its three rows (x, y, z)
  LinearVector point;           // p(q)
  bool elastic = false;         // a node of an elastic (hex27) body or of a beam
  int body = -1;                // the rigid body (a beam's node included) it is a point of; -1: an elastic node
  double regularization = 0.0;  // the tie's Tikhonov compliance c [m/N]; 0: a rigid tie
};

struct MultibodySystem {
  int coordinates = 0;
  Eigen::SparseMatrix<double> mass;  // constant
  Eigen::VectorXd constant_force;    // gravity
  ConstraintSet constraints;         // rigid-body normalisation, joints, drives
  // The constraints that hold the `hold_joints` coordinates at their initial value (used
  // while making the initial state consistent).
  ConstraintSet holds;
  std::vector<JointMeasure> joints;  // one per model joint
  Eigen::VectorXd q0, qdot0;         // the user's initial guess
  std::vector<std::unique_ptr<ForceElement>> forces;
  // Elastic bodies: their node positions are coordinates from elastic_offset[e] on.
  std::vector<std::unique_ptr<ElasticBodySpec>> elastic;
  std::vector<int> elastic_offset;
  // The rigid bodies' coordinates (beam nodes included), which come first: all but the elastic ones.
  int rigid_coordinates() const { return elastic_offset.empty() ? coordinates : elastic_offset.front(); }
  // Per elastic body: (first constraint row, node) of each clamped node's three point rows.
  std::vector<std::vector<std::pair<int, int>>> elastic_clamp_rows;
  // Resultant force and moment the clamps exert on elastic body e (moment about the clamped
  // nodes' reference centroid), from the multipliers: Φ = node − point, so −λ acts on the node.
  void ClampReaction(int e, const Eigen::VectorXd& q, const Eigen::VectorXd& lambda, Eigen::Vector3d* force,
                     Eigen::Vector3d* moment) const;

  // Total generalised force f(q, q̇, t): gravity plus every force element (with
  // `include_elastic` false: without the elastic bodies' internal forces, which CGα takes
  // from `elastic_forces` as GEMM midpoint forces).
  // `data`: the run's changing state (system_data.h, made by MakeData).
  void Force(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, const SystemData& data,
             Eigen::Ref<Eigen::VectorXd> f, bool include_elastic = true) const;
  // sink += stiffness_scale · (−∂f/∂q) + damping_scale · (−∂f/∂q̇).
  void AddForceTangent(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, const SystemData& data,
                       double stiffness_scale, double damping_scale, SparseSink* sink,
                       bool include_elastic = true) const;
  // Coupling interface nodes; the coordinates their peers impose (3 per node: x, y, z) are in
  // the run's SystemData::imposed, which the coordinator sets between iterations (the rows'
  // drives name them by index).
  std::vector<InterfacePoint> interface_points;
  // Contact laws' onset-speed slots in SystemData::impact_speed (MakeData sizes it).
  int impact_slots = 0;
  // Force [N] the smooth model exerts on interface node k, from the multipliers.
  Eigen::Vector3d InterfaceReaction(int k, const Eigen::VectorXd& lambda) const {
    return lambda.segment<3>(interface_points[static_cast<size_t>(k)].first_row);
  }
  // The beams' node bodies, root first, in model.beams' order (an impact's restart holds each
  // beam's deformation rates: ProjectImpactVelocities).
  std::vector<std::vector<int>> beam_node_bodies;
  // The beams' internal forces, in model.beams' order (also in `forces`).
  std::vector<const BeamForce*> beam_forces;
  // Per model force element (model.forces' order): its continuous contacts or joint stops (also
  // in `forces`; empty for other kinds), whose law force the CONTACT_FORCE probe reads.
  std::vector<std::vector<const UnilateralContact*>> contact_laws;
  // The air loads (also in `forces`), or null.
  const AirLoads* air_loads = nullptr;
  // The elastic bodies' internal forces (also in `forces`).
  std::vector<const ElasticForce*> elastic_forces;
  void ForcePattern(SparseSink* sink) const;
  // A step was accepted (or the run starts) at (q, q̇): force elements with a memory update it
  // in `data`.
  void AcceptStep(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, SystemData* data) const;
  // The earliest time until a continuous contact begins at the present rates (+∞: none near).
  double TimeToContact(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot) const;

  // Joint coordinate [rad or m] and its rate.
  double JointCoordinate(int joint, const Eigen::VectorXd& q) const;
  double JointRate(int joint, const Eigen::VectorXd& q, const Eigen::VectorXd& qdot) const;
  // Force [N] and moment [N m] that body1 exerts on body2 through the joint (from the
  // multipliers): the force from the point-coincidence rows (a joint without them, prismatic:
  // the generalised force all its rows put on body2's position), the moment (a pure couple, the
  // same about any point) from the orientation and drive rows.
  Eigen::Vector3d JointReactionForce(int joint, const Eigen::VectorXd& q, const Eigen::VectorXd& lambda, double t,
                                     const SystemData& data) const;
  Eigen::Vector3d JointReactionMoment(int joint, const Eigen::VectorXd& q, const Eigen::VectorXd& lambda, double t,
                                      const SystemData& data) const;
  // Position of body b's centre of mass, its axes (columns u, v, w).
  static Eigen::Vector3d Position(int body, const Eigen::VectorXd& q) {
    return q.segment<3>(kCoordinatesPerBody * body);
  }
  double KineticEnergy(const Eigen::VectorXd& qdot) const { return 0.5 * qdot.dot(mass * qdot); }
  double PotentialEnergy(const Eigen::VectorXd& q) const;
};

// `elastic` (optional) is moved into the system: its bodies' nodes become coordinates after
// the rigid bodies', clamped to rigid bodies or the ground by point rows.
MultibodySystem BuildMultibodySystem(const MultibodyModel& model, std::vector<ElasticBodySpec>* elastic = nullptr);

// The run's changing state of `system` at its start (like Pinocchio's Data(model) or MuJoCo's
// mj_makeData): the imposed coordinates where the interface points are at q0, no compliance, no
// onset speeds, one unstarted inflow state per rotor. Its owner (the simulation) passes it to
// every evaluation and integrator; a system may have several (a restart, a probe's trial).
SystemData MakeData(const MultibodySystem& system);

}  // namespace cosim::smooth
