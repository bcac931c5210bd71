// The SHARCS-like hub of the CGα paper (scenarios/sharcs/): the loop closed by the
// initial-condition solver at Table 8's hinge values, the start-up and release with the beam
// blade, and the hex27 blade against the beam blade at the end of the start-up. The full runs,
// the paper's figures and the convergence study belong in `scripts/cosim study`.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

#include "smooth_solver/simulation/multibody_simulation.h"

namespace cosim::smooth {
namespace {

const std::string kSharcs = std::string(COSIM_SOURCE_DIR) + "/scenarios/sharcs/";
constexpr double kDeg = std::numbers::pi / 180.0;

struct Probes {
  explicit Probes(const MultibodySimulation& sim) : names(sim.ProbeNames()), values(names.size()) {}
  double operator()(const std::string& name) const {
    for (size_t i = 0; i < names.size(); ++i) {
      if (names[i] == name) return values[i];
    }
    ADD_FAILURE() << "no probe " << name;
    return 0.0;
  }
  std::vector<std::string> names;
  std::vector<double> values;
};

TEST(SharcsHub, TheLoopClosesWithTheAdaptivePitchLinkAtTheLengthTableEightNeeds) {
  // Table 8: flap 1.5°, pitch 1.93°, the pitch link 0.112 m from the swashplate point
  // (0.0516, 0.03985, −0.112) m. The horn tip, 0.03985 m across the pitch axis at the flap
  // hinge's station e, is lifted by the pitch and leaned by the flap to T = (e − c sθ sβ, c cθ,
  // c sθ cβ) with c = 0.03985: the closure must lengthen the APL to |T − S| − 0.112 (1.342 mm)
  // and keep the flap, lag and pitch as given.
  MultibodySimulation sim(interface::ScenarioFile::Load(kSharcs + "hub.pbtxt", {}));
  Probes p(sim);
  sim.Probe(&p.values);
  const double beta = 1.5 * kDeg, theta = 1.93 * kDeg, c = 0.03985;
  const double dx = -c * std::sin(theta) * std::sin(beta), dy = c * std::cos(theta) - c,
               dz = c * std::sin(theta) * std::cos(beta) + 0.112;
  const double extension = std::sqrt(dx * dx + dy * dy + dz * dz) - 0.112;
  int apl = -1;
  for (size_t j = 0; j < sim.model().joints.size(); ++j) {
    if (sim.model().joints[j].name == "apl") apl = static_cast<int>(j);
  }
  ASSERT_GE(apl, 0);
  const double found = sim.system().JointCoordinate(apl, sim.integrator().state().q);
  std::printf("SHARCS closure: APL extended %.9f mm (geometry %.9f mm); flap %.6f°, pitch %.6f°, lag %.2e°\n",
              1e3 * found, 1e3 * extension, p("flap") / kDeg, p("pitch") / kDeg, p("lag") / kDeg);
  EXPECT_NEAR(found, extension, 1e-10);
  EXPECT_NEAR(p("flap"), beta, 1e-12);
  EXPECT_NEAR(p("pitch"), theta, 1e-10);
  EXPECT_NEAR(p("lag"), 0.0, 1e-12);
  EXPECT_NEAR(p("pitch_link_z_mm"), c * std::sin(theta) * std::cos(beta), 1e-10);  // the APL's top on the horn tip
  EXPECT_LT(sim.integrator().ConstraintViolation(0.0), 1e-12);
}

TEST(SharcsHub, BeamBladeSpinsUpIsReleasedAndLagsAtItsCentrifugalFrequency) {
  // hub_beam.pbtxt, the whole 0.3 s: at full speed (τ = 0.1 s) the root carries the blade's
  // centrifugal force, m Ω² r_cg = ρA L Ω² (r_root + L/2) = 11.1 kN; released, the blade lags
  // about its hinge at the centrifugal lag frequency of a uniform blade hinged at e = 0.0516 m
  // from r = 0.235 to 0.9 m: ν² = e S/I → ν = 0.296/rev, a period of 0.126 s (the lag link's,
  // pitch body's and pitch link's inertia and the blade's lag bending shift it a little).
  MultibodySimulation sim(interface::ScenarioFile::Load(kSharcs + "hub_beam.pbtxt", {}));
  Probes p(sim);
  const double h = 1e-4, omega = 168.2;
  // The lag swings between about 0 and 2.4° after the release: its upward crossings of 1.2°
  // (one per period; the blade's faster vibrations ride on it, hence the 0.03 s dead time).
  std::vector<double> crossings;
  double previous = 0.0;
  for (int k = 0; k < 3000; ++k) {
    sim.Step(k * h, h);
    sim.Probe(&p.values);
    const double lag = p("lag"), t = (k + 1) * h;
    if (t > 0.1 && previous < 1.2 * kDeg && lag >= 1.2 * kDeg && (crossings.empty() || t - crossings.back() > 0.03)) {
      crossings.push_back(t);
    }
    previous = lag;
    if (k == 999) {
      // The drive's speed, to the velocity error CGα leaves (its rate constraint is met through
      // the Newton tolerance, not projected).
      EXPECT_NEAR(p("hub_speed") / omega, 1.0, 1e-4);
      const double L = 0.66485, r_root = 0.23515, m_per_l = 1770 * 0.07 * 0.0084;
      const double cf = m_per_l * L * omega * omega * (r_root + 0.5 * L);
      std::printf("SHARCS beam at τ: root radial force %.1f N (blade centrifugal force %.1f N)\n", p("root_force_x"),
                  cf);
      EXPECT_NEAR(-p("root_force_x") / cf, 1.0, 0.01);
    }
  }
  ASSERT_GE(crossings.size(), 2u);
  const double period = crossings[1] - crossings[0];
  const double e = 0.0516, a = 0.23515 - e, b = 0.9 - e;
  const double nu = std::sqrt(e * (b * b - a * a) / 2 / ((b * b * b - a * a * a) / 3));
  const double expected = 2 * std::numbers::pi / (nu * omega);
  std::printf(
      "SHARCS beam: lag up through 1.2° at %.4f and %.4f s: period %.4f s (uniform blade on its hinge: ν = %.3f/rev, "
      "%.4f s)\n",
      crossings[0], crossings[1], period, nu, expected);
  EXPECT_NEAR(period / expected, 1.0, 0.08);
  // The loop stays closed (the projected form projects the positions onto the constraints).
  EXPECT_LT(sim.max_constraint_violation(), 1e-8);
}

TEST(SharcsHub, Hex27AndBeamBladesCarryTheSameLoadsThroughTheStartUp) {
  // The same blade as 10 hex27 elements and as 10 quadratic beam elements (hinges locked until
  // τ = 0.1 s): at t = 0.05 s, the start-up's largest angular acceleration (2640 rad/s²), the
  // in-plane root force and the tip's in-plane deflection it causes; at τ the radial root
  // force (centrifugal, 11.1 kN). The solid and the beam differ in what a beam leaves out
  // (the section's Poisson coupling, the 5/6 shear factor): a few per cent on deflections.
  struct Reading {
    double fy_mid, tip_y_mid, fx_end;
  };
  auto read = [](const std::string& file) {
    MultibodySimulation sim(interface::ScenarioFile::Load(kSharcs + file, {}));
    Probes p(sim);
    Reading r{};
    for (int k = 0; k < 1000; ++k) {
      sim.Step(k * 1e-4, 1e-4);
      if (k == 499) {
        sim.Probe(&p.values);
        r.fy_mid = p("root_force_y");
        r.tip_y_mid = p("tip_y");
      }
    }
    sim.Probe(&p.values);
    r.fx_end = p("root_force_x");
    return r;
  };
  const Reading hex = read("hub.pbtxt"), beam = read("hub_beam.pbtxt");
  std::printf(
      "SHARCS hex27 / beam: at 0.05 s in-plane root force %.1f / %.1f N, tip in-plane %.5f / %.5f m; "
      "at τ radial root force %.1f / %.1f N\n",
      hex.fy_mid, beam.fy_mid, hex.tip_y_mid, beam.tip_y_mid, hex.fx_end, beam.fx_end);
  EXPECT_NEAR(hex.fy_mid / beam.fy_mid, 1.0, 0.02);
  EXPECT_NEAR(hex.tip_y_mid / beam.tip_y_mid, 1.0, 0.05);
  EXPECT_NEAR(hex.fx_end / beam.fx_end, 1.0, 0.01);
}

}  // namespace
}  // namespace cosim::smooth
