#pragma once

// Whether the contact nodes of a coupled scene rest where they start, under the force a settled
// smooth model exerts on them (numerics.smooth.settle in a coupled run). A node at rest on
// frictionless planes takes from them only pushes along their normals, R_i n_i with R_i >= 0
// (Signorini: a plane pushes, never pulls); the rest of its load must vanish, or stay inside
// the Coulomb cones of the planes with friction. The static solve of the smooth model pins each
// interface point at its node (the tie rows' imposed values) and so cannot tell: this check
// does, from the scenario's contact nodes and obstacles.

#include <Eigen/Dense>
#include <string>
#include <vector>

#include "interface/scenario/checks.h"
#include "smooth_solver/analysis/rotating_frame.h"
#include "smooth_solver/model/multibody_system.h"

namespace cosim::smooth {

struct RestingNode {
  std::string node;                                    // the contact node's name
  std::string path;                                    // its scenario path, model.contact_nodes[i]
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // where it starts [m]
  // Its own load at rest at the start time [N]: weight, constant and prescribed forces, anchor
  // spring (no velocity, so no damping).
  Eigen::Vector3d load = Eigen::Vector3d::Zero();
  // ∂load/∂position [N/m]: the anchor spring's −k I and, in a spinning frame, −m Ω̃Ω̃.
  Eigen::Matrix3d stiffness = Eigen::Matrix3d::Zero();
  struct Plane {
    std::string obstacle;
    Eigen::Vector3d point = Eigen::Vector3d::Zero();    // a point of it [m]
    Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit, into the allowed side
    double gap = 0.0;                                   // [m], at `position`
    double friction = 0.0;                              // Coulomb μ
  };
  std::vector<Plane> planes;  // every plane it has a contact with
  bool moved = false;         // the settle moved it from where the scenario starts it
  // Moves it to x [m]: its load and its planes' gaps follow.
  void MoveTo(const Eigen::Vector3d& x);
};

// One per interface point of `system`, in its order: the node the point is tied to, read from
// the scenario at time t (the obstacles' prescribed motions at t; attached ones as written,
// which is where the contact process puts them at the start). Settled in a spinning frame, a
// node rests in it: its load takes the centrifugal force −m Ω × (Ω × r), and its initial
// velocity must be the frame's, Ω × r. InputError naming the field for a node on node springs
// (its rest depends on other nodes the settle does not move) or moving otherwise.
std::vector<RestingNode> ReadRestingNodes(const interface::Checks& checks, const MultibodySystem& system, double t,
                                          const SpinningFrame& spin);

// Whether a node rests under `force` (the smooth model's, beside its own load): empty if it
// does, else why not, in the words of the settle's refusal. `carrying`: the planes within
// `touch` of it (indices into node.planes); `push`: their normal reactions [N] (least squares).
std::string WhyNotResting(const RestingNode& node, const Eigen::Vector3d& force, double touch,
                          std::vector<int>* carrying, Eigen::VectorXd* push);

// The directions a node may move in on the planes `carrying` (indices into node.planes):
// an orthonormal basis of the complement of their normals (3 × 0..3); and the point of their
// intersection nearest its position (the node put back on them).
Eigen::MatrixXd FreeDirections(const RestingNode& node, const std::vector<int>& carrying);
Eigen::Vector3d OnPlanes(const RestingNode& node, const std::vector<int>& carrying);

// Planes within `touch` [m] of a node carry it. Fails (InputError naming the node's path, the
// force and the planes) unless, for every node, the smooth model's force on it plus its load
// is −Σ R_i n_i with R_i >= 0 over those planes, up to 1e-3 of the force plus 1e-6 N (with
// friction: a tangential remainder up to Σ μ_i R_i), and no node starts deeper than `touch`
// inside a plane. `forces[k]`: the force the smooth model exerts on node k [N].
void CheckNodesRest(const interface::Checks& checks, const std::vector<RestingNode>& nodes,
                    const std::vector<Eigen::Vector3d>& forces, double touch = 1e-6);

}  // namespace cosim::smooth
