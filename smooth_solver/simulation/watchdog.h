#pragma once
// A watchdog on invariants every smooth scene has, checked after each accepted step, so that a
// run never ends "ok" with nonsense in it (docs/design.md, "Watchdog"):
//  - every value of the state is finite;
//  - every rigid body's axis velocities are a rigid rotation: with A = [u v w] and Ȧ its rate,
//    AᵀȦ = Ω̃ + S where Ω̃ is skew (the angular velocity) and S = sym(AᵀȦ) is the velocity-level
//    rigidity residual (S = ½ d/dt (AᵀA) = 0 for a rigid body). |S|max / (|ω| + 1 rad/s) is the
//    share of the axis velocities that is not a rotation;
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

#include "interface/scenario/checks.h"
#include "scenario.pb.h"
#include "smooth_solver/integrator/smooth_integrator.h"

namespace cosim::smooth {

struct WatchdogSettings {
  double rigidity_rate = 0.01;  // 0: off
  double energy_growth = 0.1;   // 0: off
  int energy_window = 10;       // steps the growth must last
  bool energy = true;           // the energy check applies to this scene
};

// numerics.smooth.watchdog (proto/scenario/numerics.proto Watchdog): its rates and window, and
// in `energy_check` whether the energy check is asked for (AUTO decides on the system, which the
// caller has; `energy` is left as it is). Throws InputError naming the field.
WatchdogSettings ReadWatchdogSettings(const interface::Checks& checks, const scenario::Watchdog& w,
                                      scenario::Watchdog::EnergyCheck* energy_check);

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
