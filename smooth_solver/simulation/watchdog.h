#pragma once
// A watchdog on invariants every smooth scene has, checked after each accepted step, so that a
// run never ends "ok" with nonsense in it (docs/design.md, "Watchdog"):
//  - every value of the state is finite;
//  - every rigid body's axis velocities are a rigid rotation: with A = [u v w] and Ȧ its rate,
//    AᵀȦ = Ω̃ + S where Ω̃ is skew (the angular velocity) and S = sym(AᵀȦ) is the velocity-level
//    rigidity residual (S = ½ d/dt (AᵀA) = 0 for a rigid body). |S|max / (|ω| + 1 rad/s) is the
//    share of the axis velocities that is not a rotation (a beam node's against a wider bound:
//    kBeamNodeRigidityFactor);
//  - where the scene cannot gain energy (no drives, coupling rows or loads outside the potential,
//    or declared so), the total energy does not stay above its earlier lowest value by more than
//    a fraction of the scene's energy scale. The median energy of the last `energy_window` steps
//    is compared with the lowest before them, so that a transient overshoot of a few steps
//    (generalised-α with small ρ∞ on a suddenly loaded stiff body gains energy for a step or
//    two, then dissipates it) is no trip and growth that lasts is; the scale is the largest
//    kinetic energy plus the span of the potential energy before those steps (independent of
//    the potential's datum, and not inflated by the growth being measured).
// A trip throws NumericalError naming the step, the time, what grew and the setting.
#include <string>
#include <vector>

#include "smooth_solver/integrator/smooth_integrator.h"

namespace cosim::smooth {

struct WatchdogSettings {
  double rigidity_rate = 0.01;  // 0: off
  double energy_growth = 0.1;   // 0: off
  int energy_window = 10;       // steps the growth must last
  bool energy = true;           // the energy check applies to this scene
};

// A beam node's rigidity rows are closed at position level (CGα's VelocityLevelRow), so its axis
// velocities carry index 3's normal-velocity error, which CGα damps only by 1 − |1 − γ/β| a step
// (0.005 at ρ∞ = 0.9): measured up to 1.03 % of the angular speed (generated rotor 2 of the
// suite's sample, at a pad's impact; 0.32–0.45 % on rotor 707), against ~1e-9 for a body whose
// rows are closed at velocity level. Its bound is this many times rigidity_rate: a blow-up still
// crosses it within steps (the end-point beam force on rotor 707 with position-level rows: its
// tip node crossed 0.01 at 0.085 s and the run would have diverged right after).
constexpr double kBeamNodeRigidityFactor = 10.0;

class Watchdog {
 public:
  // `body_names`: the rigid bodies' names, in the system's order.
  Watchdog(const MultibodySystem& system, const WatchdogSettings& settings, std::vector<std::string> body_names,
           const DaeState& initial);

  // After the accepted step `step` (1, 2, ...) ending at t; throws NumericalError on a trip.
  void Check(const DaeState& state, double t, long step);

  // The largest values seen so far (for the summary).
  double max_rigidity_rate() const { return max_rigidity_rate_; }
  double max_energy_growth() const { return max_energy_growth_; }  // share of the energy scale
  bool energy_checked() const { return settings_.energy && settings_.energy_growth > 0.0; }

  // Velocity-level rigidity residual of rigid body b, as a share of its angular speed + 1 rad/s;
  // its angular speed into *omega.
  static double RigidityRate(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, int body, double* omega);

 private:
  void Energy(const DaeState& state, double* kinetic, double* potential) const;

  const MultibodySystem& system_;
  WatchdogSettings settings_;
  std::vector<std::string> bodies_;
  std::vector<double> rigidity_limit_;  // per body: rigidity_rate, × kBeamNodeRigidityFactor for a beam node
  struct Sample {
    double energy = 0.0, kinetic = 0.0, potential = 0.0;
  };
  std::vector<Sample> window_;  // the last energy_window steps (a ring)
  std::vector<double> sorted_;  // workspace for the window's median
  long filled_ = 0;
  // Over the steps before the window: lowest energy, largest kinetic energy, potential's span.
  double min_energy_ = 0.0, max_kinetic_ = 0.0, min_potential_ = 0.0, max_potential_ = 0.0, magnitude_ = 0.0;
  double max_rigidity_rate_ = 0.0, max_energy_growth_ = 0.0;
};

// Whether the model can gain energy only through what PotentialEnergy counts: no drives (time
// functions or imposed coordinates), no coupling interface points, every force element passive.
bool PassiveSystem(const MultibodySystem& system);

}  // namespace cosim::smooth
