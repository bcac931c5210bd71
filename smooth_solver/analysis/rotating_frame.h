#pragma once
// Static equilibrium and linearised modes of a multibody system, in the global frame or in a
// frame spinning steadily at Ω about an axis through `origin` (a rotor's fan plot).
//
// In natural coordinates every coordinate triple is a point or a direction, and the mass
// matrix is a scalar matrix ⊗ I3, so it commutes with W = I ⊗ Ω̃ (Ω × on every triple). The
// kinetic energy in the spinning frame, T = ½ (q̇ + W q̂)ᵀ M (q̇ + W q̂) with q̂ the coordinates
// with the origin taken off the points, gives
//   M q̈ + 2 M W q̇ + M W² q̂ + Φ_qᵀ λ = f(q, q̇),   Φ(q) = 0,                       (R1)
// (M W² q̂ = −centrifugal force, 2 M W q̇ the Coriolis force). Statics: q̇ = 0; modes: the
// linearisation of (R1) about that state on the null space of Φ_q. The air loads are taken at
// the absolute velocities q̇ + W q̂ (they see the spin); the other force elements are objective
// (no force for a rigid rotation) and are taken at q̇ = 0. Rotors' inflow is updated
// (AcceptStep) at every equilibrium iterate and held in the modes.
#include <Eigen/Core>
#include <complex>
#include <string>
#include <vector>

#include "smooth_solver/model/multibody_system.h"

namespace cosim::smooth {

struct SpinningFrame {
  Eigen::Vector3d omega = Eigen::Vector3d::Zero();   // [rad/s], global components
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  // a point of the spin axis [m]
};

// A coupling interface node whose position the equilibrium finds (a settled start's node that
// slides on frictionless planes, or hangs in mid-air on its tie) instead of holding it where
// the imposed values put it: x = base + T s over the directions T it may move in, with the
// node's own balance along them, Tᵀ(λ_k + load(x)) = 0 (λ_k: the force the smooth model exerts
// on it through its tie, MultibodySystem::InterfaceReaction).
struct SlidingNode {
  int point = 0;                                        // its interface point (system.interface_points)
  Eigen::Vector3d base = Eigen::Vector3d::Zero();       // a position it may take [m]
  Eigen::MatrixXd directions;                           // 3 × d, orthonormal columns (d = 1..3)
  Eigen::Vector3d load = Eigen::Vector3d::Zero();       // its own load at `base` [N]
  Eigen::Matrix3d stiffness = Eigen::Matrix3d::Zero();  // ∂load/∂x [N/m] (anchor spring, spin)
  // Planes it must not pass (point, unit normal into the allowed side): a Newton step that would
  // take it through one is cut short where it meets the first, and the solve stops there
  // (EquilibriumResult::blocked_node, blocked_guard), for the caller to let that plane carry it.
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> guards;
};

struct EquilibriumOptions {
  double t = 0.0;            // time at which loads and drives are taken
  double tolerance = 1e-10;  // on |Δq|∞ relative to 1 + |q|∞
  int max_iterations = 50;
  double max_step = 0.1;  // longest Newton step in q (|Δq|∞): metres or director components
  // Walk to a stable rest in pseudo-time (K + μ M, see StaticEquilibrium) instead of plain
  // Newton, which heads for the nearest stationary point, stable or not (the settle's solves and
  // STATIC steps).
  bool stable = false;
  // Interface nodes whose positions are unknowns too (their imposed values in `data` are set to
  // the solution; the other nodes stay where the imposed values hold them).
  std::vector<SlidingNode> sliding;
};

struct EquilibriumResult {
  Eigen::VectorXd q, lambda;
  std::vector<Eigen::Vector3d> node_positions;  // of options.sliding, in its order [m]
  // A sliding node stopped at one of its guards: (index into options.sliding, guard); −1: none.
  int blocked_node = -1, blocked_guard = -1;
  int iterations = 0;
  bool converged = false;
  bool singular = false;          // stopped on a tangent singular even with the pseudo-mass
  double residual = 0.0;          // max norm of the force and constraint residual at the end
  double initial_residual = 0.0;  // the same at the guess
};

// For a solve that did not converge: "(residual R after N Newton iterations, R0 at the start)".
std::string ResidualsText(const EquilibriumResult& r);

// The velocities of a rigid rotation with the frame, q̇ = W q̂ (Ω × every point taken from the
// origin, Ω × every direction): a state at rest in the spinning frame.
Eigen::VectorXd SpinningVelocity(const MultibodySystem& system, const Eigen::VectorXd& q, const SpinningFrame& frame);

// Newton on [−f(q, 0, t) + M W² q̂ + Φ_qᵀλ; Φ(q, t); Tᵀ(λ_k + load_k)] = 0 from `q_guess`, the
// last rows and the unknowns s of x_k = base + T s for options.sliding only (full steps: ramp
// large loads, e.g. through the loads' time functions). The rotors' inflow is updated at the
// iterates (AcceptStep: `data`, the run's changing state, changes).
EquilibriumResult StaticEquilibrium(const MultibodySystem& system, SystemData* data, const Eigen::VectorXd& q_guess,
                                    const SpinningFrame& frame, const EquilibriumOptions& options);

struct Mode {
  double frequency = 0.0;  // [rad/s], |λ| (the undamped circular frequency of the pair)
  double damping = 0.0;    // ratio −Re λ / |λ|
  std::complex<double> eigenvalue;
  Eigen::VectorXd shape;  // real part of the position part, in q (max-abs normalised)
};

// The constrained system's modes about the static state (q, λ) in the spinning frame: the
// eigenvalues of the first-order form of
//   Zᵀ M Z ÿ + Zᵀ (2 M W + C) Z ẏ + Zᵀ (K + M W² + Σ λ_i ∇²φ_i) Z y = 0,   δq = Z y,
// with Z an orthonormal basis of the null space of Φ_q, K = −∂f/∂q, C = −∂f/∂q̇ (dense:
// for analysis, not for the time loop). Sorted by frequency; rigid modes (|λ| below
// `zero_frequency`) are left out; at most `count` are returned.
std::vector<Mode> LinearModes(const MultibodySystem& system, const SystemData& data, const Eigen::VectorXd& q,
                              const Eigen::VectorXd& lambda, double t, const SpinningFrame& frame, int count,
                              double zero_frequency = 1e-6);

}  // namespace cosim::smooth
