#pragma once
// A consistent initial state from the user's guess:
//  1. positions: the smallest change of q that closes every loop and keeps the held joint
//     coordinates, min ½|q − q₀|² s.t. Φ(q, t₀) = 0, hold(q) = 0, solved as its KKT system
//     with SUNDIALS KINSOL (Newton with line search, exact sparse Jacobian factorised by KLU);
//  2. velocities: the smallest change of q̇ with Φ_q q̇ + Φ_t = 0 and the held joints' speeds
//     as given;
//  3. accelerations and multipliers from [M Φ_qᵀ; Φ_q 0][q̈; λ] = [f; −ξ].
#include "smooth_solver/integrator/cgalpha.h"

namespace cosim::smooth {

struct InitialConditionReport {
  long kinsol_iterations = 0;
  double position_change = 0.0;  // |q − q₀|∞
  double velocity_change = 0.0;  // |q̇ − q̇₀|∞
};

// Throws InputError (exit 2) when the loops cannot be closed from the guess. `data`: the run's
// changing state (MakeData(system); its imposed coordinates hold the interface points).
DaeState ConsistentInitialState(const MultibodySystem& system, const SystemData& data, double t0,
                                InitialConditionReport* report);

// The locks set by the closure (Joint.lock_at_closure) hold what the closure found: their
// constants are set so that their rows vanish at `q` (the consistent initial positions).
void HoldClosedLocks(MultibodySystem* system, const SystemData& data, const Eigen::VectorXd& q, double t0);

// The smallest change of q̇ in the kinetic-energy metric (M Δq̇ = Φ_qᵀ P: the change an impulse
// through the constraints makes) with Φ_q q̇ + Φ_t = 0 at t: after a velocity jump imposed from
// outside (a contact node's impact in a coupled run). Throws NumericalError for redundant rows
// that are not regularised.
void ProjectVelocities(const MultibodySystem& system, const SystemData& data, double t, DaeState* state);
// The velocity jump of an impact (a coupled run's restart): the `impacting` interface points take
// their nodes' new velocities (the imposed rates) by the smallest change of the rigid bodies'
// velocities in the kinetic-energy metric, the elastic coordinates (beams' nodes, hex27 bodies)
// left as they are and the other points' coupling rows left out (their ties follow). A point
// whose jump the rigid bodies cannot take to 10 % (its body clamped to a beam: the jump would
// have to bend the beam within the step) is left to its tie. Returns the points that took their
// jump (state changed), or none (state unchanged).
// `normals` (one per interface point): a point with a nonzero one takes its jump across the plane
// only, n nᵀ; along it its velocity is what the projection leaves (its node's there swings about
// the point on a stiff tie: imposed, it kicked the blade in lag).
using ImpactNormals = std::vector<Eigen::Vector3d>;
std::vector<int> ProjectImpactVelocities(const MultibodySystem& system, const SystemData& data, double t,
                                         const std::vector<int>& impacting, const ImpactNormals& normals,
                                         DaeState* state);
// After ProjectImpactVelocities: the rigid bodies moved by the smallest change in the mass metric
// that puts each of `points` on its node (the imposed values), the elastic coordinates held and
// the other points' coupling rows left out, and the velocities projected again at the new
// positions as ProjectImpactVelocities does. False (state unchanged) if a solve fails.
bool MoveImpactPointsOntoNodes(const MultibodySystem& system, const SystemData& data, double t,
                               const std::vector<int>& points, const ImpactNormals& normals, DaeState* state);

// The rigid bodies (beam nodes included) an impulse at interface point `point` moves at once
// through the constraints at positions q: those that take more than 1e-6 of its kinetic energy
// (in any of the three directions). Empty if the system is singular there.
std::vector<int> BodiesAnImpulseMoves(const MultibodySystem& system, const SystemData& data, double t,
                                      const Eigen::VectorXd& q, int point, Eigen::Matrix3d* mobility = nullptr);

}  // namespace cosim::smooth
