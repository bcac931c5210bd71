// Moreau–Jean timestepping against exact results: the bouncing ball's impact times,
// restitution and accumulation point, resting contact, and a node in a wedge.
#include "nonsmooth_solver/integrator/moreau_jean.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "tests/nonsmooth_solver/contact_scene.h"

namespace cosim::nonsmooth {
namespace {

constexpr double kG = 9.81;

ContactScene BallModel(double height, double e, const std::vector<std::string>& sets = {}) {
  const std::string text = R"(
    model {
      gravity: [0, 0, -9.81]
      obstacles { name: "ground" point: [0, 0, 0] normal: [0, 0, 1] }
      contact_nodes {
        name: "ball" mass: 1 position: [0, 0, )" +
                           std::to_string(height) + R"(]
        contacts { obstacle: "ground" restitution: )" +
                           std::to_string(e) + R"( }
      }
    }
    numerics { end_time: 1 step: 0.005 }
  )";
  return LoadContactScene(text, "ball", sets);
}

// Times (end of step) of the steps whose contact impulse exceeds `threshold`.
std::vector<double> ImpactTimes(const ContactScene& model, double h, double end, double threshold) {
  MoreauJean mj(model, model.settings, 0.0);
  std::vector<double> times;
  const long steps = std::lround(end / h);
  for (long k = 0; k < steps; ++k) {
    mj.Step(static_cast<double>(k) * h, h);
    if (mj.impulses()(0) > threshold) times.push_back(static_cast<double>(k + 1) * h);
  }
  return times;
}

// Exact impact times of the ball dropped from 1 m: t1 = sqrt(2/g), then flight k lasts
// 2 e^k v1 / g.
std::vector<double> ExactImpactTimes(double e, int count) {
  const double t1 = std::sqrt(2.0 / kG), v1 = kG * t1;
  std::vector<double> t{t1};
  for (int k = 1; k < count; ++k) t.push_back(t.back() + 2.0 * std::pow(e, k) * v1 / kG);
  return t;
}

TEST(MoreauJean, BallImpactTimesMatchTheAnalyticOnesToOrderH) {
  // The scheme places each impact in the step that contains it (with the γ = 1/2
  // look-ahead), so an impact can be off by about a step, and the offset carries into the
  // next flights: impact k (1-based) is within 2 k h of the exact time. Observed at
  // h = 0.005: 0.7, 1.1, 1.9, 3.2, 4.7 h; at h = 0.00125: 0.8, 1.6, 2.4, 2.7, 2.8 h.
  // Quartering h must cut the fifth impact's error at least in half (first order: 4×).
  const double e = 0.9;
  const ContactScene model = BallModel(1.0, e);
  const std::vector<double> exact = ExactImpactTimes(e, 5);
  double fifth_error[2] = {0.0, 0.0};
  int run = 0;
  for (double h : {0.005, 0.00125}) {
    const std::vector<double> times = ImpactTimes(model, h, 4.0, 0.05 * h / 0.005);
    ASSERT_GE(times.size(), 5u);
    for (size_t k = 0; k < 5; ++k) {
      EXPECT_NEAR(times[k], exact[k], 2.0 * static_cast<double>(k + 1) * h) << "h = " << h << ", impact " << k + 1;
    }
    fifth_error[run++] = std::abs(times[4] - exact[4]);
  }
  EXPECT_LT(fifth_error[1], 0.5 * fifth_error[0]);
}

TEST(MoreauJean, ReboundSpeedRatioIsTheRestitutionCoefficient) {
  // Newton's law is imposed on the step's end velocity: u_{k+1} = −e u_k exactly when the
  // contact is active (the LCP's w = u_{k+1} + e u_k is zero with a positive impulse).
  const double e = 0.9, h = 0.005;
  const ContactScene model = BallModel(1.0, e);
  MoreauJean mj(model, model.settings, 0.0);
  for (int k = 0; k < 200; ++k) {
    const double before = mj.velocities()(2);
    mj.Step(k * h, h);
    if (mj.impulses()(0) > 0.0) {
      EXPECT_NEAR(mj.velocities()(2) / before, -e, 1e-12);
      return;
    }
  }
  FAIL() << "no impact in 1 s";
}

// Time from which the ball stays at rest (zero velocity) until `end`; -1 if it never does.
double RestTime(double h, double end, MoreauJean* mj) {
  double rest_since = -1.0;
  const long steps = std::lround(end / h);
  for (long k = 0; k < steps; ++k) {
    mj->Step(static_cast<double>(k) * h, h);
    const bool at_rest = std::abs(mj->velocities()(2)) < 1e-12;
    if (at_rest && rest_since < 0.0) rest_since = static_cast<double>(k + 1) * h;
    if (!at_rest) rest_since = -1.0;
  }
  return rest_since;
}

TEST(MoreauJean, BallComesToRestAtTheAccumulationTimeAsHShrinks) {
  // Bounces accumulate at t∞ = t1 (1 + e)/(1 − e) = 8.579 s. The discrete ball stops once a
  // rebound no longer clears the look-ahead; each impact's O(h) timing error adds up over the
  // many bounces, so the rest time approaches t∞ as h shrinks (observed: 9.365, 9.110, 8.830 s
  // for h = 0.005, 0.0025, 0.00125). After that the impulse balances gravity, r = m g h.
  const double e = 0.9;
  const ContactScene model = BallModel(1.0, e);
  const double t_inf = std::sqrt(2.0 / kG) * (1.0 + e) / (1.0 - e);
  // The error is about 160-210 h over this range; quartering h must cut it at least in half.
  double previous_error = 1e9, first_error = 0.0;
  for (double h : {0.005, 0.0025, 0.00125}) {
    MoreauJean mj(model, model.settings, 0.0);
    const double rest = RestTime(h, 11.0, &mj);
    ASSERT_GT(rest, 0.0) << "h = " << h << ": the ball never came to rest";
    const double error = std::abs(rest - t_inf);
    std::printf("h = %.5f: at rest from t = %.4f s (t_inf = %.4f s)\n", h, rest, t_inf);
    EXPECT_LT(error, previous_error) << "h = " << h;
    if (first_error == 0.0) first_error = error;
    previous_error = error;
    EXPECT_NEAR(mj.impulses()(0), 1.0 * kG * h, 1e-12);
    EXPECT_NEAR(mj.positions()(2), 0.0, 1e-3);  // rests on the plane, within O(h v) of it
  }
  EXPECT_LT(previous_error, 0.5 * first_error);
}

TEST(MoreauJean, NodeOnAPlaneStaysAtRestWithImpulseMgh) {
  // At rest on the plane the LCP gives r = m g h each step (the impulse that cancels gravity
  // over the step), and the node neither moves nor sinks: all exact up to round-off.
  const double h = 0.01;
  const ContactScene model = BallModel(0.0, 0.5);
  MoreauJean mj(model, model.settings, 0.0);
  for (int k = 0; k < 100; ++k) {
    mj.Step(k * h, h);
    ASSERT_NEAR(mj.impulses()(0), kG * h, 1e-13);
    ASSERT_NEAR(mj.positions()(2), 0.0, 1e-15);
    ASSERT_NEAR(mj.velocities()(2), 0.0, 1e-15);
  }
}

TEST(MoreauJean, NodeInAWedgeIsHeldByTwoContacts) {
  // Two planes inclined ±30° from horizontal meet at the origin. A node resting in the
  // groove is held by both; by symmetry each impulse is m g h / (2 cos 30°).
  const double h = 0.01, c = std::cos(M_PI / 6), s = std::sin(M_PI / 6);
  const std::string text = R"(
    model {
      gravity: [0, 0, -9.81]
      obstacles { name: "left" point: [0, 0, 0] normal: [)" +
                           std::to_string(s) + ", 0, " + std::to_string(c) + R"(] }
      obstacles { name: "right" point: [0, 0, 0] normal: [)" +
                           std::to_string(-s) + ", 0, " + std::to_string(c) + R"(] }
      contact_nodes {
        name: "n" mass: 2 position: [0, 0, 0]
        contacts { obstacle: "left" restitution: 0 }
        contacts { obstacle: "right" restitution: 0 }
      }
    }
    numerics { end_time: 1 step: 0.01 }
  )";
  const ContactScene model = LoadContactScene(text, "wedge", {});
  MoreauJean mj(model, model.settings, 0.0);
  for (int k = 0; k < 50; ++k) mj.Step(k * h, h);
  const double expected = 2.0 * kG * h / (2.0 * c);
  EXPECT_NEAR(mj.impulses()(0), expected, 1e-6 * expected);  // normals given with 6 digits
  EXPECT_NEAR(mj.impulses()(1), expected, 1e-6 * expected);
  EXPECT_LT(mj.positions().norm(), 1e-12);
}

TEST(MoreauJean, FirstImpactTimeConvergesToFirstOrder) {
  // The impact is located to within one step, so the error of the first impact time is O(h).
  // Over two decades of h the least-squares slope of log error against log h is about 1;
  // the per-step phase of t1 within the grid scatters single points, hence many step sizes
  // and a band of ±0.3 around the slope.
  const ContactScene model = BallModel(1.0, 0.9);
  const double t1 = std::sqrt(2.0 / kG);
  std::vector<double> lh, le;
  for (int j = 0; j < 13; ++j) {
    const double h = 0.02 * std::pow(10.0, -j / 6.0);
    const std::vector<double> times = ImpactTimes(model, h, 0.6, 0.0);
    ASSERT_FALSE(times.empty());
    lh.push_back(std::log(h));
    le.push_back(std::log(std::abs(times[0] - t1)));
  }
  const double n = static_cast<double>(lh.size());
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (size_t i = 0; i < lh.size(); ++i) {
    sx += lh[i];
    sy += le[i];
    sxx += lh[i] * lh[i];
    sxy += lh[i] * le[i];
  }
  const double slope = (n * sxy - sx * sy) / (n * sxx - sx * sx);
  std::printf("first-impact-time error slope: %.3f\n", slope);
  EXPECT_NEAR(slope, 1.0, 0.3);
}

// A linear oscillator (m = 1, k = 100, anchored at z = 0, no gravity) released from z = A
// hits a stop plane at z = −d.
ContactScene OscillatorModel(double amplitude, double stop, double e) {
  const std::string text = R"(
    model {
      obstacles { name: "stop" point: [0, 0, )" +
                           std::to_string(-stop) + R"(] normal: [0, 0, 1] }
      contact_nodes {
        name: "m" mass: 1 position: [0, 0, )" +
                           std::to_string(amplitude) + R"(]
        anchor { point: [0, 0, 0] stiffness: 100 }
        contacts { obstacle: "stop" restitution: )" +
                           std::to_string(e) + R"( }
      }
    }
    numerics { end_time: 1 step: 0.001 }
  )";
  return LoadContactScene(text, "oscillator", {});
}

TEST(MoreauJean, OscillatorAgainstAStopReboundsToTheAnalyticAmplitude) {
  // Before the stop the motion is x = A cos(ωt), ω = 10 rad/s; it reaches x = −d at
  // t_c = acos(−d/A)/ω with speed v_c = A ω sin(ω t_c). Newton's law sends it back at e v_c, so
  // the next free oscillation has amplitude A' = sqrt(d² + (e v_c/ω)²) and peaks a quarter
  // period after leaving the stop. The θ = 1/2 scheme conserves the energy of the free linear
  // oscillator exactly, so the only errors are the O(h) impact location (A' to ~1e-3 at
  // h = 1e-4) and the O(h²) phase.
  const double A = 0.1, d = 0.05, e = 0.8, omega = 10.0, h = 1e-4;
  const ContactScene model = OscillatorModel(A, d, e);
  MoreauJean mj(model, model.settings, 0.0);
  const double tc = std::acos(-d / A) / omega;
  const double vc = A * omega * std::sin(omega * tc);
  const double amplitude_after = std::sqrt(d * d + std::pow(e * vc / omega, 2));
  double impact_time = -1.0, peak = -1.0, min_z = 1.0;
  for (int k = 0; k < 10000 && peak < 0.0; ++k) {
    const double before = mj.velocities()(2);
    mj.Step(static_cast<double>(k) * h, h);
    const double z = mj.positions()(2), v = mj.velocities()(2);
    min_z = std::min(min_z, z);
    if (impact_time < 0.0 && mj.impulses()(0) > 0.0) impact_time = static_cast<double>(k + 1) * h;
    if (impact_time > 0.0 && before > 0.0 && v <= 0.0) peak = z;  // first maximum after the impact
  }
  ASSERT_GT(impact_time, 0.0);
  std::printf("oscillator: impact at %.5f s (exact %.5f), rebound peak %.6f m (exact %.6f)\n", impact_time, tc, peak,
              amplitude_after);
  EXPECT_NEAR(impact_time, tc, 2.0 * h);
  EXPECT_NEAR(peak, amplitude_after, 1e-3 * A);
  EXPECT_GT(min_z, -d - vc * h);  // penetration at most one step's travel
}

TEST(MoreauJean, ElasticOscillatorKeepsItsEnergyAndThePeriodOfTheStoppedMotion) {
  // With e = 1 the rebound is elastic: the motion is periodic with period 2 t_c (from +A to
  // the stop and back) and the energy ½ k A² is kept, apart from the O(h) energy error of
  // each impact step. Over ten periods at h = 1e-4 the energy stays within 1 % and the tenth
  // return to the top is within 10 steps of 20 t_c.
  const double A = 0.1, d = 0.05, omega = 10.0, h = 1e-4;
  const ContactScene model = OscillatorModel(A, d, 1.0);
  MoreauJean mj(model, model.settings, 0.0);
  const double tc = std::acos(-d / A) / omega;
  const double energy0 = mj.KineticEnergy(-1) + mj.PotentialEnergy(-1);
  int tops = 0;
  double tenth_top = -1.0;
  for (int k = 0; k < 50000 && tops < 10; ++k) {
    const double before = mj.velocities()(2);
    mj.Step(static_cast<double>(k) * h, h);
    if (before > 0.0 && mj.velocities()(2) <= 0.0) {
      ++tops;
      if (tops == 10) tenth_top = static_cast<double>(k + 1) * h;
    }
    ASSERT_NEAR(mj.KineticEnergy(-1) + mj.PotentialEnergy(-1), energy0, 0.01 * energy0)
        << "t = " << static_cast<double>(k + 1) * h;
  }
  ASSERT_EQ(tops, 10);
  std::printf("elastic oscillator: tenth top at %.5f s (exact %.5f)\n", tenth_top, 20.0 * tc);
  EXPECT_NEAR(tenth_top, 20.0 * tc, 10.0 * h);
}

TEST(MoreauJean, BallTrajectoryMatchesSiconosKernel) {
  // tests/data/siconos_kernel_ball.csv is the same bouncing ball integrated by Siconos' own
  // kernel (MoreauJeanOSI θ = 1/2 with its LCP; made by benchmarks/siconos_kernel_ball.py):
  // every 10th step of 2000, through 20 impacts and the accumulation. Both run the same
  // scheme with the same index-set rule, so they agree to round-off (observed 5e-15 m).
  std::ifstream in(std::string(COSIM_SOURCE_DIR) + "/tests/data/siconos_kernel_ball.csv");
  ASSERT_TRUE(in) << "missing tests/data/siconos_kernel_ball.csv";
  std::string line;
  std::getline(in, line);
  std::vector<std::array<double, 3>> reference;
  while (std::getline(in, line)) {
    std::array<double, 3> row{};
    std::istringstream s(line);
    char comma = 0;
    s >> row[0] >> comma >> row[1] >> comma >> row[2];
    reference.push_back(row);
  }
  ASSERT_EQ(reference.size(), 201u);
  const ContactScene model = BallModel(1.0, 0.9);
  MoreauJean mj(model, model.settings, 0.0);
  const double h = 0.005;
  double worst = 0.0;
  for (size_t r = 1; r < reference.size(); ++r) {
    for (int k = 0; k < 10; ++k) mj.Step(static_cast<double>((r - 1) * 10 + static_cast<size_t>(k)) * h, h);
    ASSERT_NEAR(mj.positions()(2), reference[r][1], 1e-10) << "t = " << reference[r][0];
    ASSERT_NEAR(mj.velocities()(2), reference[r][2], 1e-9) << "t = " << reference[r][0];
    worst = std::max(worst, std::abs(mj.positions()(2) - reference[r][1]));
  }
  std::printf("largest height difference from Siconos' kernel: %.2e m\n", worst);
}

TEST(MoreauJean, IndependentNodesOnlyTheTouchingOneFeelsAnImpulse) {
  // Two nodes, each with its own floor: one starts on it, the other 1 m above. Contacts of
  // different nodes do not interact, so the resting node gets exactly m g h per step and the
  // falling one none until it lands at t = sqrt(2/g) (the LCP is then a corner of the workspace).
  const std::string text = R"(
    model {
      gravity: [0, 0, -9.81]
      obstacles { name: "floor_a" point: [0, 0, 0] normal: [0, 0, 1] }
      obstacles { name: "floor_b" point: [5, 0, 0] normal: [0, 0, 1] }
      contact_nodes { name: "a" mass: 2 position: [0, 0, 1] contacts { obstacle: "floor_a" restitution: 0 } }
      contact_nodes { name: "b" mass: 3 position: [5, 0, 0] contacts { obstacle: "floor_b" restitution: 0 } }
    }
    numerics { end_time: 1 step: 0.001 }
  )";
  const ContactScene model = LoadContactScene(text, "two", {});
  MoreauJean mj(model, model.settings, 0.0);
  const double h = 0.001;
  for (int k = 0; k < 800; ++k) {
    mj.Step(static_cast<double>(k) * h, h);
    ASSERT_NEAR(mj.impulses()(1), 3.0 * kG * h, 1e-12) << "step " << k;
    if (static_cast<double>(k + 1) * h < std::sqrt(2.0 / kG) - 2.0 * h) {
      ASSERT_EQ(mj.impulses()(0), 0.0) << "step " << k;
    }
  }
  EXPECT_NEAR(mj.positions()(2), 0.0, 1e-2);  // node a has landed (e = 0) and rests
  EXPECT_NEAR(mj.velocities()(2), 0.0, 1e-12);
  EXPECT_NEAR(mj.positions()(5), 0.0, 1e-15);
}

TEST(MoreauJean, NodeIsCarriedByARisingPlane) {
  // A floor rising at V = 0.5 m/s under a node at rest on it (e = 0). The plane's motion
  // enters the gap rate as −n·V, so the first step's LCP lifts the node to exactly V (impulse
  // m (V + g h)); afterwards it rides along with impulse m g h per step. The velocity-level
  // scheme does not correct positions: the θ = 1/2 update leaves the node V h / 2 behind the
  // plane after the first step, and that gap stays constant.
  const std::string text = R"(
    model {
      gravity: [0, 0, -9.81]
      obstacles { name: "lift" point: [0, 0, 0] normal: [0, 0, 1] prescribed { velocity: [0, 0, 0.5] } }
      contact_nodes { name: "n" mass: 2 position: [0, 0, 0] contacts { obstacle: "lift" restitution: 0 } }
    }
    numerics { end_time: 1 step: 0.01 }
  )";
  const ContactScene model = LoadContactScene(text, "lift", {});
  MoreauJean mj(model, model.settings, 0.0);
  const double h = 0.01, V = 0.5, m = 2.0;
  mj.Step(0.0, h);
  EXPECT_NEAR(mj.velocities()(2), V, 1e-14);
  EXPECT_NEAR(mj.impulses()(0), m * (V + kG * h), 1e-13);
  for (int k = 1; k < 100; ++k) {
    mj.Step(static_cast<double>(k) * h, h);
    ASSERT_NEAR(mj.velocities()(2), V, 1e-13) << "step " << k;
    ASSERT_NEAR(mj.impulses()(0), m * kG * h, 1e-12) << "step " << k;
    ASSERT_NEAR(mj.Gap(0), -V * h / 2.0, 1e-13) << "step " << k;
  }
}

TEST(MoreauJean, PeerForceActsLikeAConstantForce) {
  // The coupling peer's reaction enters as an external force held over the step. Given as
  // (0, 0, 3) N it must produce exactly the trajectory of the same force given in the
  // scenario: both enter the free velocity the same way.
  const std::string base = R"(
    model {
      gravity: [0, 0, -9.81]
      obstacles { name: "ground" point: [0, 0, 0] normal: [0, 0, 1] }
      contact_nodes { name: "n" mass: 1 position: [0, 0, 1] contacts { obstacle: "ground" restitution: 0.5 } }
    }
    numerics { end_time: 1 step: 0.001 })";
  const ContactScene scenario_force = LoadContactScene(base, "a", {"model.contact_nodes[0].force=[0, 0, 3]"});
  const ContactScene plain = LoadContactScene(base, "b", {});
  MoreauJean a(scenario_force, scenario_force.settings, 0.0), b(plain, plain.settings, 0.0);
  b.SetExternalForces(Eigen::Vector3d(0.0, 0.0, 3.0));
  for (int k = 0; k < 1500; ++k) {
    a.Step(static_cast<double>(k) * 1e-3, 1e-3);
    b.Step(static_cast<double>(k) * 1e-3, 1e-3);
  }
  EXPECT_EQ(a.positions(), b.positions());
  EXPECT_EQ(a.velocities(), b.velocities());
  EXPECT_GT(a.stats().activations, 0);  // it did reach the ground
}

}  // namespace
}  // namespace cosim::nonsmooth
