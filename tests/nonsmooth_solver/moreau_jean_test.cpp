// Moreau–Jean timestepping against exact results: the bouncing ball's impact times,
// restitution and accumulation point, resting contact, and a node in a wedge.
#include "nonsmooth_solver/integrator/moreau_jean.h"

#include <gtest/gtest.h>

#include <cmath>

namespace cosim::nonsmooth {
namespace {

constexpr double kG = 9.81;

ContactModel BallModel(double height, double e, const std::vector<std::string>& sets = {}) {
  const std::string text = R"(
    model {
      gravity: [0, 0, -9.81]
      obstacles { name: "ground" point: [0, 0, 0] normal: [0, 0, 1] }
      contact_nodes {
        name: "ball" mass: 1 position: [0, 0, )" + std::to_string(height) + R"(]
        contacts { obstacle: "ground" restitution: )" + std::to_string(e) + R"( }
      }
    }
    numerics { end_time: 1 step: 0.005 }
  )";
  return BuildContactModel(interface::ScenarioFile::Parse(text, "ball", sets));
}

// Times (end of step) of the steps whose contact impulse exceeds `threshold`.
std::vector<double> ImpactTimes(const ContactModel& model, double h, double end, double threshold) {
  MoreauJean mj(model, 0.0);
  std::vector<double> times;
  const long steps = std::lround(end / h);
  for (long k = 0; k < steps; ++k) {
    mj.Step(static_cast<double>(k) * h, h);
    if (mj.impulses()(0) > threshold) times.push_back(static_cast<double>(k + 1) * h);
  }
  return times;
}

TEST(MoreauJean, BallImpactTimesMatchTheAnalyticOnesWithinAStep) {
  // Free fall from 1 m reaches the plane at t1 = sqrt(2/g); each rebound leaves with e times
  // the arrival speed, so flight k lasts 2 e^k v1 / g. The scheme captures each impact in
  // the step that contains it (plus the γ = 1/2 look-ahead), so every impact time is within
  // 2h of the exact one over the first five bounces.
  const double e = 0.9, h = 0.005;
  const ContactModel model = BallModel(1.0, e);
  const std::vector<double> times = ImpactTimes(model, h, 4.0, 0.05);
  const double t1 = std::sqrt(2.0 / kG), v1 = kG * t1;
  double exact = t1;
  ASSERT_GE(times.size(), 5u);
  for (int k = 0; k < 5; ++k) {
    EXPECT_NEAR(times[static_cast<size_t>(k)], exact, 2.0 * h) << "impact " << k + 1;
    exact += 2.0 * std::pow(e, k + 1) * v1 / kG;
  }
}

TEST(MoreauJean, ReboundSpeedRatioIsTheRestitutionCoefficient) {
  // Newton's law is imposed on the step's end velocity: u_{k+1} = −e u_k exactly when the
  // contact is active (the LCP's w = u_{k+1} + e u_k is zero with a positive impulse).
  const double e = 0.9, h = 0.005;
  const ContactModel model = BallModel(1.0, e);
  MoreauJean mj(model, 0.0);
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

TEST(MoreauJean, BallComesToRestNearTheAccumulationTimeAndStaysThere) {
  // Bounces accumulate at t∞ = t1 (1 + e)/(1 − e) = 8.578 s. The discrete scheme stops
  // bouncing once a rebound no longer clears the look-ahead, a little before t∞ (within a
  // few tenths of a second at h = 0.005), then the impulse balances gravity: r = m g h.
  const double e = 0.9, h = 0.005;
  const ContactModel model = BallModel(1.0, e);
  MoreauJean mj(model, 0.0);
  const double t_inf = std::sqrt(2.0 / kG) * (1.0 + e) / (1.0 - e);
  double rest_since = -1.0;
  const long steps = std::lround(10.0 / h);
  for (long k = 0; k < steps; ++k) {
    mj.Step(static_cast<double>(k) * h, h);
    const bool at_rest = std::abs(mj.velocities()(2)) < 1e-12;
    if (at_rest && rest_since < 0.0) rest_since = static_cast<double>(k + 1) * h;
    if (!at_rest) rest_since = -1.0;
  }
  ASSERT_GT(rest_since, 0.0) << "the ball never came to rest";
  EXPECT_NEAR(rest_since, t_inf, 0.5);
  EXPECT_NEAR(mj.impulses()(0), 1.0 * kG * h, 1e-12);
  EXPECT_NEAR(mj.positions()(2), 0.0, 1e-3);  // rests on the plane, within O(h v) of it
}

TEST(MoreauJean, NodeOnAPlaneStaysAtRestWithImpulseMgh) {
  // At rest on the plane the LCP gives r = m g h each step (the impulse that cancels gravity
  // over the step), and the node neither moves nor sinks: all exact up to round-off.
  const double h = 0.01;
  const ContactModel model = BallModel(0.0, 0.5);
  MoreauJean mj(model, 0.0);
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
      obstacles { name: "left" point: [0, 0, 0] normal: [)" + std::to_string(s) + ", 0, " + std::to_string(c) + R"(] }
      obstacles { name: "right" point: [0, 0, 0] normal: [)" + std::to_string(-s) + ", 0, " + std::to_string(c) + R"(] }
      contact_nodes {
        name: "n" mass: 2 position: [0, 0, 0]
        contacts { obstacle: "left" restitution: 0 }
        contacts { obstacle: "right" restitution: 0 }
      }
    }
    numerics { end_time: 1 step: 0.01 }
  )";
  const ContactModel model = BuildContactModel(interface::ScenarioFile::Parse(text, "wedge", {}));
  MoreauJean mj(model, 0.0);
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
  const ContactModel model = BallModel(1.0, 0.9);
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

}  // namespace
}  // namespace cosim::nonsmooth
