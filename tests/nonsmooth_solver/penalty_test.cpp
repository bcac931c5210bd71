// penalty_solver's contact method on its own: a ball dropped on the floor rebounds with the
// contact's Newton e as the contact stiffness grows (the law's e is solved for it), and bad
// settings are refused naming the field.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "interface/base/errors.h"
#include "interface/scenario/scenario_file.h"
#include "nonsmooth_solver/penalty/penalty_simulation.h"

namespace cosim::nonsmooth {
namespace {

const char* kBall = R"(
  name: "ball"
  model {
    gravity: [0, 0, -9.81]
    obstacles { name: "floor" point: [0, 0, 0] normal: [0, 0, 1] }
    contact_nodes { name: "ball" mass: 1 position: [0, 0, 0.5] contacts { obstacle: "floor" restitution: 0.8 } }
  }
  numerics { end_time: 1 step: 1e-4 penalty { stiffness: 1e6 } }
)";

// The first rebound's peak height [m].
double Rebound(double stiffness) {
  PenaltySimulation sim(
      interface::ScenarioFile::Parse(kBall, "ball", {"numerics.penalty.stiffness=" + std::to_string(stiffness)}));
  double peak = 0.0;
  bool bounced = false;
  for (int k = 0; k < 10000; ++k) {
    sim.Step(k * 1e-4, 1e-4);
    const double z = sim.positions()(2), vz = sim.velocities()(2);
    if (z < 0.0) bounced = true;
    if (bounced && z > 0.0) peak = std::max(peak, z);
    if (bounced && z > 0.0 && vz < 0.0) break;
  }
  return peak;
}

TEST(Penalty, ReboundApproachesNewtonsLawAsTheStiffnessGrows) {
  // e² h0 = 0.32 m in the limit; a compliant contact lasts ~K^(-2/5) with gravity acting and
  // the ball sinking into the floor (observed 0.3160, 0.3187, 0.3211 m for K = 1e6, 1e7, 1e8;
  // at 1e8 the 2 ms contact has only 20 steps of 0.1 ms, which the trapezoidal rule pays for
  // with +0.3 %).
  const double a = Rebound(1e6), b = Rebound(1e7), c = Rebound(1e8);
  EXPECT_LT(std::abs(0.32 - c), 0.5 * (0.32 - a));
  EXPECT_LT(a, b);
  EXPECT_LT(b, c);
  EXPECT_NEAR(c, 0.32, 2e-3);
}

TEST(Penalty, CheckpointRestoresTheStepStart) {
  // Coupling iterations repeat a step from its start: the same forces give the same step.
  PenaltySimulation sim(interface::ScenarioFile::Parse(kBall, "ball", {}));
  for (int k = 0; k < 3100; ++k) sim.Step(k * 1e-4, 1e-4);  // into the contact
  sim.SaveStart();
  sim.Step(0.31, 1e-4);
  const Eigen::VectorXd once = sim.positions();
  sim.RestoreStart();
  sim.Step(0.31, 1e-4);
  EXPECT_EQ((sim.positions() - once).norm(), 0.0);
}

std::string ErrorOf(const std::vector<std::string>& sets) {
  try {
    PenaltySimulation sim(interface::ScenarioFile::Parse(kBall, "ball", sets));
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(Penalty, BadSettingsAreRefusedNamingTheField) {
  EXPECT_NE(ErrorOf({"numerics.penalty.stiffness=-1"}).find("numerics.penalty.stiffness"), std::string::npos);
  EXPECT_NE(ErrorOf({"numerics.penalty.substeps=0"}).find("numerics.penalty.substeps"), std::string::npos);
  EXPECT_NE(ErrorOf({"model.contact_nodes[0].contacts[0].friction=0.3"}).find("frictionless"), std::string::npos);
  EXPECT_NE(ErrorOf({"model.contact_nodes[0].contacts[0].restitution=0"}).find("e > 0"), std::string::npos);
  EXPECT_NE(ErrorOf({"numerics.penalty={}"}).find("numerics.penalty.stiffness"), std::string::npos);
}

}  // namespace
}  // namespace cosim::nonsmooth
