// A blade clamped to a hub that spins up (scenarios/spinning_blade.pbtxt): the centrifugal
// load stretches it radially as a bar under ρΩ²r, and centrifugal stiffening raises its flap
// frequency by the Southwell coefficient of a rotating cantilever. Also: elastic node loads act
// in DYNAMIC runs, and a damped dynamic run settles on the static solution.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "interface/scenario/scenario_file.h"
#include "smooth_solver/elastic/elastic_body.h"
#include "smooth_solver/simulation/multibody_simulation.h"

namespace cosim::smooth {
namespace {

const double kDensity = 2700, kYoung = 7e10, kRoot = 0.1, kLength = 1.0, kChord = 0.1, kThickness = 0.01;

struct SpinRun {
  double radial_stretch = 0.0;  // mean tip-centre radius − (root + length), 0.55 .. 0.6 s [m]
  double flap_frequency = 0.0;  // from the tip's zero crossings after the pulse [rad/s]
  double root_force = 0.0;      // |clamp force| at 0.6 s [N]
  double violation = 0.0;
};

SpinRun RunSpinningBlade(double omega) {
  MultibodySimulation sim(interface::ScenarioFile::Load(
      std::string(COSIM_SOURCE_DIR) + "/scenarios/spinning_blade.pbtxt",
      {"model.joints[0].drive.function.cosine_ramp.final_value=" + std::to_string(omega)}));
  // Probes: hub_angle, tip_x, tip_y, tip_z, root_force_x, root_force_y, strain_energy, violation,
  // then the hub-frame ones.
  std::vector<double> v(sim.ProbeNames().size());
  SpinRun run;
  const double h = 0.002;
  int samples = 0;
  std::vector<double> crossings;
  double previous_z = 0.0;
  for (int k = 0; k < 550; ++k) {
    const double t1 = (k + 1) * h;
    sim.Step(k * h, h);
    sim.Probe(&v);
    run.violation = std::max(run.violation, v[7]);
    if (t1 > 0.55 - 1e-9 && t1 < 0.6 - 1e-9) {
      run.radial_stretch += std::hypot(kRoot + kLength + v[1], v[2]) - (kRoot + kLength);
      ++samples;
    }
    if (std::abs(t1 - 0.6) < 1e-9) run.root_force = std::hypot(v[4], v[5]);
    if (t1 > 0.62 && previous_z != 0.0 && (previous_z < 0.0) != (v[3] < 0.0)) {
      crossings.push_back(t1 - h * v[3] / (v[3] - previous_z));  // linear interpolation
    }
    previous_z = v[3];
  }
  run.radial_stretch /= samples;
  // Half a period between successive crossings; average over all of them.
  run.flap_frequency = M_PI * static_cast<double>(crossings.size() - 1) / (crossings.back() - crossings.front());
  return run;
}

// Euler–Bernoulli flap frequency of a uniform rotating cantilever (root offset r0), by
// Rayleigh–Ritz with the polynomials (x/L)^k, k = 2..9: bending stiffness plus the geometric
// stiffness of the centrifugal tension N(x) = ρAΩ² [(r0 L + L²/2) − (r0 x + x²/2)].
// `bending_scale` multiplies EI (the 3-D strip is stiffer than a beam; only the Ω² part is
// compared below). Gauss–Legendre (16 points) integration is exact for these polynomials.
double RitzFlapFrequency(double omega, double bending_scale) {
  const int n = 8;
  const double A = kChord * kThickness, I = kChord * std::pow(kThickness, 3) / 12.0, L = kLength;
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(n, n), M = Eigen::MatrixXd::Zero(n, n);
  // 16-point Gauss–Legendre on [0, L] from the Golub–Welsch eigenproblem.
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(16, 16);
  for (int i = 1; i < 16; ++i) J(i, i - 1) = J(i - 1, i) = i / std::sqrt(4.0 * i * i - 1.0);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> gw(J);
  for (int g = 0; g < 16; ++g) {
    const double x = 0.5 * L * (gw.eigenvalues()(g) + 1.0), w = L * gw.eigenvectors()(0, g) * gw.eigenvectors()(0, g);
    const double N = kDensity * A * omega * omega * ((kRoot * L + 0.5 * L * L) - (kRoot * x + 0.5 * x * x));
    Eigen::VectorXd phi(n), d1(n), d2(n);
    for (int k = 0; k < n; ++k) {
      const double p = k + 2.0, s = x / L;
      phi(k) = std::pow(s, p);
      d1(k) = p * std::pow(s, p - 1.0) / L;
      d2(k) = p * (p - 1.0) * std::pow(s, p - 2.0) / (L * L);
    }
    K += w * (bending_scale * kYoung * I * d2 * d2.transpose() + N * d1 * d1.transpose());
    M += w * kDensity * A * phi * phi.transpose();
  }
  Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> eig(K, M);
  return std::sqrt(eig.eigenvalues()(0));
}

TEST(SpinningBlade, RadialStretchAndCentrifugalStiffening) {
  // Radial stretch: a bar under the centrifugal load ρΩ²r, N(r) = ρAΩ²(R² − r²)/2, stretches
  // by u(R) = ρΩ²/(2E) [R²(R − r0) − (R³ − r0³)/3] = 3.70e-5 m at Ω = 50 rad/s (R = 1.1 m);
  // the 3-D blade's root clamp restrains the Poisson contraction, which stiffens it a little
  // (observed 1.1 % short). Asserted to 2 %. The root force is the blade's centrifugal force
  // m Ω² r_cg (2.7 kg, r_cg = 0.6 m: 4050 N; observed 0.17 % more, the stretched blade's)
  // to 0.5 %.
  // Flap frequency: ω² = ω0² + K Ω² (Southwell). K from an Euler–Bernoulli Ritz model with
  // the measured ω0 (the 3-D strip, chord 10× its thickness, is stiffer in bending than a
  // beam by up to 1/(1 − ν²): observed ω0 = 53.16 rad/s against the beam's 51.68; only the
  // centrifugal part K Ω² is compared). Observed K = 1.354 against the beam model's 1.337
  // (1.3 %: the strip is not a beam, and 6 elements); asserted to 4 %; the frequency rises by
  // 48 % (53.2 → 78.8 rad/s).
  const double omega = 50.0;
  const SpinRun still = RunSpinningBlade(0.0), spinning = RunSpinningBlade(omega);
  const double R = kRoot + kLength;
  const double stretch =
      kDensity * omega * omega / (2.0 * kYoung) * (R * R * kLength - (R * R * R - kRoot * kRoot * kRoot) / 3.0);
  const double mass = kDensity * kChord * kThickness * kLength;
  const double centrifugal = mass * omega * omega * (kRoot + 0.5 * kLength);
  // EI scale that reproduces the measured non-rotating frequency, then K at Ω.
  const double beam_still = RitzFlapFrequency(0.0, 1.0);
  const double scale = std::pow(still.flap_frequency / beam_still, 2);
  const double beam_spinning = RitzFlapFrequency(omega, scale);
  const double k_beam = (beam_spinning * beam_spinning - still.flap_frequency * still.flap_frequency) / (omega * omega);
  const double k_measured =
      (spinning.flap_frequency * spinning.flap_frequency - still.flap_frequency * still.flap_frequency) /
      (omega * omega);
  std::printf("spinning blade: radial stretch %.4e m (bar theory %.4e), root force %.1f N (m Ω² r_cg %.1f)\n",
              spinning.radial_stretch, stretch, spinning.root_force, centrifugal);
  std::printf(
      "flap frequency: still %.3f rad/s (beam %.3f), at %.0f rad/s %.3f rad/s; Southwell K %.4f (beam model "
      "%.4f)\n",
      still.flap_frequency, beam_still, omega, spinning.flap_frequency, k_measured, k_beam);
  EXPECT_NEAR(spinning.radial_stretch, stretch, 0.02 * stretch);
  EXPECT_NEAR(spinning.root_force, centrifugal, 0.005 * centrifugal);
  EXPECT_NEAR(k_measured, k_beam, 0.04 * k_beam);
  EXPECT_GT(spinning.flap_frequency, 1.4 * still.flap_frequency);
  EXPECT_LT(spinning.violation, 1e-9);
  EXPECT_LT(still.radial_stretch, 1e-9);  // no spin, no stretch (the flap pulse comes later)
}

}  // namespace
}  // namespace cosim::smooth

namespace cosim::smooth {
namespace {

TEST(DynamicCantilever, HeavilyDampedRunSettlesOnTheStaticSolution) {
  // The static cantilever of the CGα paper (scenarios/cantilever_static.pbtxt, 10 kN at the tip)
  // run DYNAMIC from rest with ρ∞ = 0: the load acts as a step, and the asymptotic annihilation
  // of ρ∞ = 0 removes the vibration (first bending mode ωh = 6.5 at h = 1e-3 s) within a few
  // dozen steps, leaving the static equilibrium: tip uy = 2.8265e-5 m as in the static solve
  // (Cantilever.StaticTipDisplacementsMatchTables1And2), to 1e-6 relative after 60 steps.
  // It checks that node loads act in DYNAMIC runs and that the inertia-free limit of the
  // dynamic equations is the static one.
  MultibodySimulation sim(interface::ScenarioFile::Load(
      std::string(COSIM_SOURCE_DIR) + "/scenarios/cantilever_static.pbtxt",
      {"numerics.smooth.analysis=DYNAMIC", "numerics.smooth.rho_inf=0", "numerics.step=0.001", "numerics.end_time=0.06",
       "numerics.smooth.newton_tolerance=1e-12"}));
  std::vector<double> v(5);
  for (int k = 0; k < 60; ++k) sim.Step(k * 0.001, 0.001);
  sim.Probe(&v);
  ElasticBody body;
  body.Initialize(BeamMesh(1.0, 0.2, 0.1, 10, 1, 1, {}), ElasticMaterial{1770, 1.792e12, 0.3});
  const StaticResult s =
      SolveStatic(body, body.mesh().root_face, {{body.mesh().tip_centre, Eigen::Vector3d(0, 1e4, 0)}}, 1e-12, 20);
  const double static_uy = s.displacement(1, body.mesh().tip_centre);
  std::printf("dynamic cantilever after 60 steps: tip uy %.8e m (static solve %.8e), root force %.4f N\n", v[0],
              static_uy, v[3]);
  EXPECT_NEAR(v[0], static_uy, 1e-6 * static_uy);
  EXPECT_NEAR(v[3], -1e4, 1e-3);
}

}  // namespace
}  // namespace cosim::smooth
