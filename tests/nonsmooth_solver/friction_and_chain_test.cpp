// Coulomb friction (polyhedral LCP and Siconos' fc3d), chains of masses linked by springs,
// and the equivalence of split and single LCPs.
#include <gtest/gtest.h>

#include <cmath>

#include "interface/scenario/checks.h"
#include "nonsmooth_solver/integrator/moreau_jean.h"
#include "tests/nonsmooth_solver/contact_scene.h"

namespace cosim::nonsmooth {
namespace {

constexpr double kG = 9.81;

ContactScene Parse(const std::string& text, const std::vector<std::string>& sets = {}) {
  return LoadContactScene(text, "test", sets);
}

// A node sliding on the floor at 2 m/s in direction (cos a, sin a, 0), μ = 0.3.
std::string SlidingNode(double direction) {
  return R"(
    model {
      gravity: [0, 0, -9.81]
      obstacles { name: "floor" point: [0, 0, 0] normal: [0, 0, 1] }
      contact_nodes {
        name: "block" mass: 2 position: [0, 0, 0]
        velocity: [)" +
         interface::FormatNumber(2.0 * std::cos(direction)) + ", " +
         interface::FormatNumber(2.0 * std::sin(direction)) +
         R"(, 0]
        contacts { obstacle: "floor" restitution: 0 friction: 0.3 }
      }
    }
    numerics { end_time: 1 step: 0.001 })";
}

void ExpectDecelerationMuG(const ContactScene& model, double direction, double tolerance) {
  // Sliding, the friction impulse is μ r_n = μ m g h per step against the motion: the speed
  // drops by μ g h each step, v(t) = v0 − μ g t, until it reaches zero at t = v0/(μ g) =
  // 0.680 s; then the block sticks (zero speed, zero friction once gravity is balanced).
  MoreauJean mj(model, model.settings, 0.0);
  const double h = 0.001, v0 = 2.0, mu = 0.3;
  const Eigen::Vector3d along(std::cos(direction), std::sin(direction), 0.0);
  for (int k = 0; k < 1000; ++k) {
    mj.Step(static_cast<double>(k) * h, h);
    const double t = static_cast<double>(k + 1) * h;
    const Eigen::Vector3d v = mj.velocities().head<3>();
    const double expected = std::max(v0 - mu * kG * t, 0.0);
    ASSERT_NEAR(v.dot(along), expected, tolerance) << "t = " << t;
    ASSERT_NEAR((v - v.dot(along) * along).norm(), 0.0, tolerance) << "t = " << t << ": the block veered";
    ASSERT_NEAR(mj.impulses()(0), 2.0 * kG * h, tolerance) << "t = " << t;
  }
}

TEST(Friction, PolyhedralConeDeceleratesAtMuGAlongAFacet) {
  // The 8-facet cone has a facet along −x, so sliding along +x meets the exact Coulomb
  // force: Lemke's pivots make the result exact to round-off.
  ExpectDecelerationMuG(Parse(SlidingNode(0.0)), 0.0, 1e-12);
}

TEST(Friction, SiconosFc3dDeceleratesAtMuGInAnyDirection) {
  // The exact (circular) cone has no preferred direction: sliding at 30° decelerates at μg
  // along its own direction. fc3d's NSGS meets the 1e-12 tolerance on this one-contact
  // problem, so the speed follows v0 − μ g t to about that.
  ExpectDecelerationMuG(Parse(SlidingNode(M_PI / 6), {"numerics.nonsmooth.friction_model=SICONOS_FC3D",
                                                      "numerics.nonsmooth.lcp.tolerance=1e-12"}),
                        M_PI / 6, 1e-9);
}

TEST(Friction, BlockOnASteepSlopeSlidesAndOnAGentleSlopeSticks) {
  // On a slope of angle α the block sticks if tan α <= μ and otherwise slides down with
  // acceleration g (sin α − μ cos α). μ = 0.3: α = 10° sticks, α = 30° slides at 2.356 m/s².
  for (double degrees : {10.0, 30.0}) {
    const double a = degrees * M_PI / 180.0;
    const std::string text = R"(
      model {
        gravity: [0, 0, -9.81]
        obstacles { name: "slope" point: [0, 0, 0] normal: [)" +
                             interface::FormatNumber(-std::sin(a)) + ", 0, " + interface::FormatNumber(std::cos(a)) +
                             R"(] }
        contact_nodes { name: "block" mass: 1 position: [0, 0, 0] contacts { obstacle: "slope" restitution: 0 friction: 0.3 } }
      }
      numerics { end_time: 1 step: 0.001 })";
    const ContactScene model = Parse(text);
    MoreauJean mj(model, model.settings, 0.0);
    for (int k = 0; k < 500; ++k) mj.Step(static_cast<double>(k) * 0.001, 0.001);
    const double speed = mj.velocities().head<3>().norm();
    const double expected = std::max(0.0, kG * (std::sin(a) - 0.3 * std::cos(a))) * 0.5;
    // Exact for the discrete scheme too: constant acceleration, integrated step by step.
    EXPECT_NEAR(speed, expected, 1e-12) << degrees << "°";
  }
}

// A chain of three unit masses linked by springs (k = 1000 N/m), falling at 1 m/s without
// gravity onto a floor that the lowest mass hits at t = 0.1 s.
std::string Chain(double restitution) {
  std::string text = R"(
    model {
      obstacles { name: "floor" point: [0, 0, 0] normal: [0, 0, 1] }
  )";
  for (int i = 0; i < 3; ++i) {
    text += "contact_nodes { name: \"m" + std::to_string(i) + "\" mass: 1 position: [0, 0, " +
            std::to_string(0.1 + 0.1 * i) +
            "] velocity: [0, 0, -1] contacts { obstacle: \"floor\" restitution: " + std::to_string(restitution) +
            " } }\n";
  }
  text += R"(
      node_springs { name: "s01" node1: "m0" node2: "m1" stiffness: 1000 }
      node_springs { name: "s12" node1: "m1" node2: "m2" stiffness: 1000 }
    }
    numerics { end_time: 1 step: 0.0001 })";
  return text;
}

TEST(Chain, MomentumChangesExactlyByTheContactImpulses) {
  // Springs are internal forces and there is no gravity, so in every step the chain's total
  // momentum changes by exactly the sum of the contact impulses (to round-off).
  const ContactScene model = Parse(Chain(0.5));
  ASSERT_EQ(model.groups.size(), 1u);  // the springs make the three nodes one group
  MoreauJean mj(model, model.settings, 0.0);
  const double h = 1e-4;
  double momentum = mj.velocities().sum();
  double impulses = 0.0;
  for (int k = 0; k < 5000; ++k) {
    mj.Step(static_cast<double>(k) * h, h);
    impulses += mj.impulses().sum();
    ASSERT_NEAR(mj.velocities()(2) + mj.velocities()(5) + mj.velocities()(8) - momentum, impulses, 1e-12);
  }
  EXPECT_GT(impulses, 1.0);  // the chain did hit and rebound (initial momentum −3 N s)
  (void)momentum;
}

TEST(Chain, ElasticImpactConservesTheEnergyExactly) {
  // With θ = 1/2 the update q_{k+1} − q_k = h (v_{k+1} + v_k)/2 makes the spring work equal
  // the change of spring energy, so the energy changes only by ½ Σ r_i (u_i,k+1 + u_i,k).
  // With e = 1 every active contact has either r_i = 0 or u_i,k+1 = −u_i,k: the discrete
  // energy is conserved to round-off through the impacts, at any step size.
  for (double h : {1e-4, 2.5e-5}) {
    const ContactScene model = Parse(Chain(1.0));
    MoreauJean mj(model, model.settings, 0.0);
    const double e0 = mj.KineticEnergy(-1) + mj.PotentialEnergy(-1);
    const long steps = std::lround(0.6 / h);
    for (long k = 0; k < steps; ++k) mj.Step(static_cast<double>(k) * h, h);
    ASSERT_GT(mj.positions()(2), 0.0);
    ASSERT_GT(mj.velocities().sum(), 0.0) << "the chain should be moving away from the floor";
    const double e1 = mj.KineticEnergy(-1) + mj.PotentialEnergy(-1);
    std::printf("h = %.1e: energy after the bounce %.15f J (before %.15f J)\n", h, e1, e0);
    EXPECT_NEAR(e1, e0, 1e-10 * e0);  // observed 1e-12 relative
  }
}

TEST(SplitLcps, GiveTheSameTrajectoryAsOneLcp) {
  // Contacts of nodes not linked by springs are independent: the Delassus matrix is block
  // diagonal, so solving each block alone (default) must reproduce the single LCP of Eq. (5).
  // One contact per node has friction (polyhedral cone), which makes the LCPs degenerate at
  // times: Siconos' Lemke then fails some of them (n = 11 split, n = 22 whole) and the
  // default fallbacks (enumerative up to n = 12, then Newton–FB) solve them; the
  // trajectories still agree to 1e-12.
  std::string text = "model {\n gravity: [0, 0, -9.81]\n";
  for (int i = 0; i < 4; ++i) {
    const std::string x = std::to_string(3.0 * i), id = std::to_string(i);
    text += " obstacles { name: \"l" + id + "\" point: [" + x + ", 0, 0] normal: [0.5, 0, 0.8660254037844386] }\n";
    text += " obstacles { name: \"r" + id + "\" point: [" + x + ", 0, 0] normal: [-0.5, 0, 0.8660254037844386] }\n";
    text += " contact_nodes { name: \"n" + id + "\" mass: 1 position: [" + std::to_string(3.0 * i + 0.05) + ", 0, " +
            std::to_string(0.2 + 0.01 * i) + "] contacts { obstacle: \"l" + id +
            "\" restitution: 0.5 friction: 0.2 } contacts { obstacle: \"r" + id + "\" restitution: 0.5 } }\n";
  }
  text += "}\nnumerics { end_time: 1 step: 0.001 }\n";
  const ContactScene split = Parse(text);
  const ContactScene single = Parse(text, {"numerics.nonsmooth.split_independent_lcps=false"});
  MoreauJean a(split, split.settings, 0.0), b(single, single.settings, 0.0);
  for (int k = 0; k < 1000; ++k) {
    a.Step(static_cast<double>(k) * 0.001, 0.001);
    b.Step(static_cast<double>(k) * 0.001, 0.001);
    ASSERT_LT((a.positions() - b.positions()).lpNorm<Eigen::Infinity>(), 1e-12) << "step " << k;
  }
  EXPECT_GT(a.stats().lcp_solves, b.stats().lcp_solves);  // the split did solve more, smaller LCPs
  std::printf("LCP solves (fallbacks): split %lld (%lld), single %lld (%lld)\n", a.stats().lcp_solves,
              a.stats().lcp_fallbacks, b.stats().lcp_solves, b.stats().lcp_fallbacks);
}

TEST(MovingPlanes, StickingNodeRidesATiltingFloor) {
  // A floor through the origin tilts about the y axis by φ(t), a cosine ramp to 0.3 rad over
  // 1 s. A node resting on it at x = 0.5 m with μ = 1 > tan 0.3 sticks, so it follows the
  // floor's material point: at t = 1 s it is at R_y(0.3)·(0.5, 0, 0). This exercises the
  // rotating normal and tangents and the plane's point velocity ω × (x − p) in the normal
  // and friction rows. Siconos' Lemke fails on some of these sticking LCPs (degenerate: the
  // eight facet directions span a plane) and the default enumerative fallback solves them.
  // Observed position error 9.0e-6, 2.2e-6, 5.6e-7 m: second order; asserted: it at least
  // halves with h and stays below h/100.
  const std::string text = R"(
    model {
      gravity: [0, 0, -9.81]
      obstacles {
        name: "floor" point: [0, 0, 0] normal: [0, 0, 1]
        prescribed { rotation_axis: [0, 1, 0] rotation_angle { cosine_ramp { final_value: 0.3 ramp_time: 1 } } }
      }
      contact_nodes { name: "n" mass: 1 position: [0.5, 0, 0] contacts { obstacle: "floor" restitution: 0 friction: 1 } }
    }
    numerics { end_time: 1 step: 0.001 })";
  const ContactScene model = Parse(text);
  const Eigen::Vector3d expected(0.5 * std::cos(0.3), 0.0, -0.5 * std::sin(0.3));
  double previous = 1.0;
  for (double h : {1e-3, 5e-4, 2.5e-4}) {
    MoreauJean mj(model, model.settings, 0.0);
    const long steps = std::lround(1.0 / h);
    for (long k = 0; k < steps; ++k) mj.Step(static_cast<double>(k) * h, h);
    const double error = (mj.positions().head<3>() - expected).norm();
    std::printf("h = %.2e: position error %.3e m, gap %.3e m\n", h, error, mj.Gap(0));
    EXPECT_LT(error, 0.5 * previous) << "h = " << h;
    EXPECT_LT(error, 0.01 * h) << "h = " << h;
    previous = error;
  }
}

TEST(TimeForces, LinearForceRampIsIntegratedExactly) {
  // A free node (no gravity) pushed by F_x(t) = 4 t N (a table from 0 to 4 N over 1 s):
  // v = 2 t² / m, x = 2 t³ / (3 m). With θ = 1/2 the velocity update is the trapezoidal rule,
  // exact for a linear force, so v(1) = 2/m to round-off; the position, a trapezoidal sum of
  // v, carries an O(h²) error: h²/6 · Δv̇ ... = 2h²/(6m)·... below 1e-6 at h = 1e-3.
  const std::string text = R"(
    model {
      contact_nodes {
        name: "n" mass: 2 position: [0, 0, 0]
        force_function { table { time: [0, 1] value: [0, 4] } }
        force_function { constant: 0 }
        force_function { constant: 0 }
      }
    }
    numerics { end_time: 1 step: 0.001 })";
  const ContactScene model = Parse(text);
  MoreauJean mj(model, model.settings, 0.0);
  for (int k = 0; k < 1000; ++k) mj.Step(static_cast<double>(k) * 1e-3, 1e-3);
  EXPECT_NEAR(mj.velocities()(0), 2.0 / 2.0, 1e-12);
  EXPECT_NEAR(mj.positions()(0), 2.0 / (3.0 * 2.0), 1e-6);
}

}  // namespace
}  // namespace cosim::nonsmooth
