#include "smooth_solver/simulation/watchdog.h"

#include <algorithm>
#include <cmath>

#include "interface/base/errors.h"
#include "interface/scenario/checks.h"

namespace cosim::smooth {

using interface::FormatNumber;

bool PassiveSystem(const MultibodySystem& system) {
  if (!system.constraints.drives.empty() || !system.interface_points.empty()) return false;
  return std::all_of(system.forces.begin(), system.forces.end(), [](const auto& f) { return f->Passive(); });
}

double Watchdog::RigidityRate(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, int body, double* omega) {
  const int o = kCoordinatesPerBody * body + 3;
  Eigen::Matrix3d A, Ad;
  for (int k = 0; k < 3; ++k) {
    A.col(k) = q.segment<3>(o + 3 * k);
    Ad.col(k) = qdot.segment<3>(o + 3 * k);
  }
  const Eigen::Matrix3d W = A.transpose() * Ad;
  const Eigen::Matrix3d S = 0.5 * (W + W.transpose());  // ½ d/dt (AᵀA): 0 for a rigid motion
  // Skew part Ω̃ = ½ (W − Wᵀ): body-frame angular velocity (Ω̃_32, Ω̃_13, Ω̃_21).
  *omega = Eigen::Vector3d(0.5 * (W(2, 1) - W(1, 2)), 0.5 * (W(0, 2) - W(2, 0)), 0.5 * (W(1, 0) - W(0, 1))).norm();
  return S.cwiseAbs().maxCoeff() / (*omega + 1.0);
}

WatchdogSettings ReadWatchdogSettings(const interface::Checks& checks, const scenario::Watchdog& w,
                                      scenario::Watchdog::EnergyCheck* energy_check) {
  WatchdogSettings out;
  out.rigidity_rate =
      checks.NonNegative("numerics.smooth.watchdog.rigidity_rate", w.rigidity_rate(), "dimensionless; 0 = off");
  out.energy_growth =
      checks.NonNegative("numerics.smooth.watchdog.energy_growth", w.energy_growth(), "dimensionless; 0 = off");
  if (w.energy_window() < 1) {
    checks.Fail("numerics.smooth.watchdog.energy_window",
                "must be >= 1 step, got " + std::to_string(w.energy_window()));
  }
  out.energy_window = w.energy_window();
  if (w.energy_check() != scenario::Watchdog::AUTO && w.energy_check() != scenario::Watchdog::ON &&
      w.energy_check() != scenario::Watchdog::OFF) {
    checks.Fail("numerics.smooth.watchdog.energy_check", "expected AUTO, ON or OFF");
  }
  *energy_check = w.energy_check();
  return out;
}

Watchdog::Watchdog(const MultibodySystem& system, const WatchdogSettings& settings, std::vector<std::string> body_names,
                   const DaeState& initial)
    : system_(system), settings_(settings), bodies_(std::move(body_names)) {
  double kinetic = 0.0, potential = 0.0;
  Energy(initial, &kinetic, &potential);
  min_energy_ = kinetic + potential;
  max_kinetic_ = kinetic;
  min_potential_ = max_potential_ = potential;
  magnitude_ = std::abs(kinetic) + std::abs(potential);
  window_.assign(static_cast<size_t>(std::max(1, settings_.energy_window)), Sample{});
  sorted_.assign(window_.size(), 0.0);
}

void Watchdog::Energy(const DaeState& state, double* kinetic, double* potential) const {
  *kinetic = system_.KineticEnergy(state.qdot);
  *potential = system_.PotentialEnergy(state.q);
}

void Watchdog::Check(const DaeState& state, double t, long step) {
  // Built only for a message (the check itself allocates nothing).
  auto when = [&] { return "at t = " + FormatNumber(t) + " s (step " + std::to_string(step) + ")"; };
  const std::pair<const Eigen::VectorXd*, const char*> parts[4] = {{&state.q, "positions"},
                                                                   {&state.qdot, "velocities"},
                                                                   {&state.qddot, "accelerations"},
                                                                   {&state.lambda, "multipliers"}};
  for (const auto& [v, what] : parts) {
    if (!v->allFinite()) {
      throw NumericalError("watchdog: non-finite " + std::string(what) + " " + when() +
                           "; the integration has broken down");
    }
  }
  if (settings_.rigidity_rate > 0.0) {
    for (size_t b = 0; b < bodies_.size(); ++b) {
      double omega = 0.0;
      const double rate = RigidityRate(state.q, state.qdot, static_cast<int>(b), &omega);
      max_rigidity_rate_ = std::max(max_rigidity_rate_, rate);
      if (rate > settings_.rigidity_rate) {
        throw NumericalError(
            "watchdog: body '" + bodies_[b] + "' is no longer moving rigidly " + when() +
            ": the non-rigid part of its axis "
            "velocities, |sym(AᵀȦ)| = " +
            FormatNumber(rate * (omega + 1.0)) + " 1/s, is " + FormatNumber(rate) + " of its angular speed " +
            FormatNumber(omega) +
            " rad/s + 1 rad/s (numerics.smooth.watchdog.rigidity_rate = " + FormatNumber(settings_.rigidity_rate) +
            "); the integrator has lost the velocity-level rigidity constraints "
            "(with constraint_form INDEX3: use INDEX2_PROJECTED, or reduce the step)");
      }
    }
  }
  if (energy_checked()) {
    Sample now;
    Energy(state, &now.kinetic, &now.potential);
    now.energy = now.kinetic + now.potential;
    magnitude_ = std::max(magnitude_, std::abs(now.kinetic) + std::abs(now.potential));
    // The ring holds the last W steps; the one it drops joins the record of the steps before.
    const size_t w = window_.size();
    Sample& slot = window_[static_cast<size_t>(filled_) % w];
    if (filled_ >= static_cast<long>(w)) {
      min_energy_ = std::min(min_energy_, slot.energy);
      max_kinetic_ = std::max(max_kinetic_, slot.kinetic);
      min_potential_ = std::min(min_potential_, slot.potential);
      max_potential_ = std::max(max_potential_, slot.potential);
    }
    slot = now;
    ++filled_;
    if (filled_ < static_cast<long>(w)) return;  // growth must last W steps
    // The window's median: a few steps of overshoot do not move it, nor do the deep dips of an
    // energy that swings wildly while it grows (the index-3 blow-ups: their minimum stays low).
    for (size_t i = 0; i < w; ++i) sorted_[i] = window_[i].energy;
    std::nth_element(sorted_.begin(), sorted_.begin() + static_cast<std::ptrdiff_t>(w / 2), sorted_.end());
    const double typical = sorted_[w / 2];
    const double growth = typical - min_energy_;
    // Round-off of a sum whose terms are `magnitude_` (a potential far from its datum) is no growth.
    const double scale = std::max(max_kinetic_ + (max_potential_ - min_potential_), 1e-9 * magnitude_);
    if (growth > 1e-9 * magnitude_ && scale > 0.0) {
      const double share = growth / scale;
      max_energy_growth_ = std::max(max_energy_growth_, share);
      if (share > settings_.energy_growth) {
        throw NumericalError("watchdog: the total energy grew " + when() + " from " + FormatNumber(min_energy_) +
                             " J to a median of " + FormatNumber(typical) + " J over the last " + std::to_string(w) +
                             " steps (now " + FormatNumber(now.energy) + " J): " + FormatNumber(share) +
                             " of the scene's energy scale before them, " + FormatNumber(scale) +
                             " J (numerics.smooth.watchdog.energy_growth = " + FormatNumber(settings_.energy_growth) +
                             "), in a scene that cannot gain energy (no drives, coupling or non-potential loads); "
                             "reduce the step, or set watchdog.energy_check: OFF if energy does enter it");
      }
    }
  }
}

}  // namespace cosim::smooth
