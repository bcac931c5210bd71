// Coupling interface nodes on the smooth side (rotor-sailing paper, Eqs. (6)-(7)): a body's
// material point follows the position a peer imposes, through three coincidence rows whose
// multipliers are the force on the contact node, optionally regularised (Φ − cλ = 0).
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "interface/base/errors.h"
#include "interface/scenario/scenario_file.h"
#include "smooth_solver/integrator/cgalpha.h"
#include "smooth_solver/integrator/initial_conditions.h"
#include "smooth_solver/model/multibody_model.h"
#include "smooth_solver/model/multibody_system.h"
#include "smooth_solver/simulation/multibody_simulation.h"

namespace cosim::smooth {
namespace {

// A free 1 kg rod (no joints: its point has three free translations, so the three coincidence
// rows are independent) whose centre of mass is tied to contact node "tip". A hinged rod tied
// at its end would be overconstrained (3 rows for 1 degree of freedom): that is the closed loop
// the regularisation is for, and its consistent initial state is still to do.
std::string TiedPendulum(double regularization) {
  return R"(
    name: "tied_pendulum"
    model {
      gravity: [0, 0, -9.81]
      bodies { name: "arm" mass: 1 inertia: [0.001, 0.08, 0.08] position: [0.5, 0, 0] }
      obstacles { name: "floor" point: [0, 0, -1] normal: [0, 0, 1] }
      contact_nodes { name: "tip" mass: 0.1 position: [0.5, 0, 0] contacts { obstacle: "floor" } }
    }
    coupling { interface_nodes { contact_node: "tip" body: "arm" point: [0, 0, 0] regularization: )" +
         std::to_string(regularization) + R"( } }
    numerics { end_time: 1 step: 0.001 })";
}

TEST(InterfacePoint, AHeldPointCarriesTheBodysWeight) {
  // The peer holds the point where it is: the rod hangs on it (gravity acts at that very
  // point, so nothing turns), and the coincidence multipliers are the force the rod exerts on
  // the node: its weight, (0, 0, −9.81) N, with the rod at rest (1e-12).
  const interface::ScenarioFile file = interface::ScenarioFile::Parse(TiedPendulum(0.0), "tied.pbtxt", {});
  const MultibodyModel model = BuildMultibodyModel(file);
  const MultibodySystem sys = BuildMultibodySystem(model);
  ASSERT_EQ(sys.interface_points.size(), 1u);
  InitialConditionReport report;
  SystemData data = MakeData(sys);
  const DaeState initial = ConsistentInitialState(sys, data, 0.0, &report);
  CgAlpha integrator(sys, &data, CgAlphaSettings{}, initial);
  for (int k = 0; k < 100; ++k) integrator.Step(k * 1e-3, 1e-3);
  const Eigen::Vector3d reaction = sys.InterfaceReaction(0, integrator.state().lambda);
  EXPECT_NEAR(reaction.z(), -9.81, 1e-9);
  EXPECT_NEAR(reaction.x(), 0.0, 1e-9);
  EXPECT_LT(integrator.state().qdot.norm(), 1e-12);
}

// The rod of tests/data/envelope/settled_stop.pbtxt: 1 kg, 1 m, on a hinge, its tip tied
// (1e-7 m/N) to a contact node.
constexpr const char* kHingedTiedRod = R"(
    name: "hinged_tied_rod"
    model {
      gravity: [0, 0, -9.81]
      bodies { name: "rod" mass: 1 inertia: [0.08333333333333333, 0.08333333333333333, 1e-4]
               position: [0.5, 0, 0] rotation: [0, 1.5707963267948966, 0] }
      joints { name: "hinge" type: REVOLUTE body1: "ground" body2: "rod" point: [0, 0, 0] axis: [0, 1, 0] }
      contact_nodes { name: "tip" mass: 0.1 position: [1, 0, 0] }
    }
    coupling { interface_nodes { contact_node: "tip" body: "rod" point: [0, 0, 0.5] regularization: 1e-7 } }
    numerics { end_time: 1 step: 0.001 })";

TEST(InterfacePoint, AStepsSolutionDoesNotDependOnTheGuessNewtonStartsFrom) {
  // A coupling iteration redoes the step from its start with the imposed coordinates moved and
  // Newton started from the last solve. In a first step the start-up's a_0 depends on the
  // imposed coordinates, so that solve's velocities belong to another predictor: taken whole as
  // the guess, Newton converged to a different root (the tie's reaction 5.27 N instead of 4.905 N
  // on the settled rod of tests/data/envelope/settled_stop.pbtxt). Here that rod, level, takes a
  // first step with its tip's node 4.9e-7 m low (the pre-solve), then again with the node where
  // it was, from that solve and from the predictor: the same end state (before the fix, the
  // reactions 8.948 N and 8.585 N, the speeds 1.1e-4 m/s apart).
  const interface::ScenarioFile file = interface::ScenarioFile::Parse(kHingedTiedRod, "rod.pbtxt", {});
  const MultibodySystem sys = BuildMultibodySystem(BuildMultibodyModel(file));
  SystemData data = MakeData(sys);
  InitialConditionReport report;
  const DaeState initial = ConsistentInitialState(sys, data, 0.0, &report);
  const double held = data.imposed[2].value;
  CgAlphaSettings settings;
  settings.tolerance = 1e-12;
  CgAlpha integrator(sys, &data, settings, initial);
  CgAlpha::Checkpoint start;
  integrator.SaveTo(&start);
  data.imposed[2].value = held - 4.9e-7;
  ASSERT_TRUE(integrator.TryStep(0.0, 1e-3).ok());
  const DaeState pre_solve = integrator.state();
  integrator.Restore(start);
  data.imposed[2].value = held;
  ASSERT_TRUE(integrator.TryStep(0.0, 1e-3, &pre_solve).ok());
  const DaeState warm = integrator.state();
  integrator.Restore(start);
  data.imposed[2].value = held;
  ASSERT_TRUE(integrator.TryStep(0.0, 1e-3).ok());
  const DaeState& cold = integrator.state();
  const double warm_z = sys.InterfaceReaction(0, warm.lambda).z(), cold_z = sys.InterfaceReaction(0, cold.lambda).z();
  std::printf("tie reaction after the first step: %.9f N from the pre-solve, %.9f N from the predictor\n", warm_z,
              cold_z);
  EXPECT_NEAR(warm_z, cold_z, 1e-6 * std::abs(cold_z));
  EXPECT_LT((warm.q - cold.q).lpNorm<Eigen::Infinity>(), 1e-12);
  EXPECT_LT((warm.qdot - cold.qdot).lpNorm<Eigen::Infinity>(), 1e-9);
}

TEST(InterfacePoint, ImposedMotionIsFollowedAndRegularisationYields) {
  // The peer lowers the point by 1 cm: the rod follows (its point is where the peer says, to
  // the Newton tolerance). With c = 1e-3 m/N the row is Φ = cλ: at rest the point sits below
  // the imposed one by c |λ_z| = 9.81 mm (Φ = p − x = c λ_z), which is what Eq. (7) trades
  // for a regular Jacobian in closed loops. Held still after a jump, the rod bounces on the
  // compliant rows (ω = 1/√(c m) ≈ 32 rad/s) and ρ∞ = 0.9 damps that slowly: 3 s of 1 ms steps.
  for (double c : {0.0, 1e-3}) {
    const interface::ScenarioFile file = interface::ScenarioFile::Parse(TiedPendulum(c), "tied.pbtxt", {});
    const MultibodySystem sys = BuildMultibodySystem(BuildMultibodyModel(file));
    SystemData data = MakeData(sys);
    InitialConditionReport report;
    const DaeState initial = ConsistentInitialState(sys, data, 0.0, &report);
    CgAlphaSettings settings;
    settings.tolerance = 1e-12;
    settings.rho_inf = 0.5;
    CgAlpha integrator(sys, &data, settings, initial);
    data.imposed[2].value = -0.01;  // z of the point
    // Critically slow: many small steps with the lowered point held, until the rod is at rest.
    for (int k = 0; k < 3000; ++k) integrator.Step(k * 1e-3, 1e-3);
    const Eigen::Vector3d end = sys.interface_points[0].point.Value(integrator.state().q);
    const double lambda_z = sys.InterfaceReaction(0, integrator.state().lambda).z();
    EXPECT_NEAR(end.z() - (-0.01), c * lambda_z, 1e-6) << "c = " << c;
  }
}

TEST(InterfacePoint, StandaloneSmoothRunOfACoupledSceneIsRefused) {
  try {
    MultibodySimulation sim(interface::ScenarioFile::Parse(TiedPendulum(0.0), "tied.pbtxt", {}));
    FAIL() << "accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("coupling.interface_nodes"), std::string::npos) << e.what();
  }
}

TEST(InterfacePoint, UnknownContactNodeOrBodyIsBadInput) {
  std::string text = TiedPendulum(0.0);
  text.replace(text.find("contact_node: \"tip\""), 19, "contact_node: \"tap\"");
  try {
    BuildMultibodyModel(interface::ScenarioFile::Parse(text, "tied.pbtxt", {}));
    FAIL() << "accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("coupling.interface_nodes[0].contact_node"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("no contact node named 'tap'; known: tip"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace cosim::smooth
