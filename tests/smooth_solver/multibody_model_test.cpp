// The multibody model builder rejects inconsistent scenes with the field named.
#include "smooth_solver/model/multibody_model.h"

#include <gtest/gtest.h>

#include "interface/base/errors.h"

namespace cosim::smooth {
namespace {

const char* kPendulum = R"(
model {
  gravity: [0, 0, -9.81]
  bodies { name: "bob" mass: 1 inertia: [0.01, 0.01, 0.01] position: [1, 0, 0] }
  joints { name: "hinge" type: REVOLUTE body1: "ground" body2: "bob" point: [0, 0, 0] axis: [0, 1, 0] }
}
numerics { end_time: 1 step: 0.001 }
)";

std::string ErrorOf(const std::vector<std::string>& sets) {
  try {
    BuildMultibodyModel(interface::ScenarioFile::Parse(kPendulum, "p.pbtxt", sets));
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(MultibodyModel, BuildsAValidPendulum) {
  // Well-formed: one body, one hinge to ground, axis normalised.
  const MultibodyModel m = BuildMultibodyModel(interface::ScenarioFile::Parse(kPendulum, "p.pbtxt", {}));
  ASSERT_EQ(m.bodies.size(), 1u);
  EXPECT_EQ(m.joints[0].body1, -1);
  EXPECT_DOUBLE_EQ(m.joints[0].axis.norm(), 1.0);
}

TEST(MultibodyModel, RejectsInconsistentScenes) {
  EXPECT_NE(ErrorOf({"model.joints[0].body2=rotor"}).find("no body named 'rotor'; known: bob"), std::string::npos);
  EXPECT_NE(ErrorOf({"model.joints[0].axis=[0, 0, 0]"}).find("non-zero direction"), std::string::npos);
  EXPECT_NE(ErrorOf({"model.bodies[0].inertia=[1, 1, -1]"}).find("positive definite"), std::string::npos);
  EXPECT_NE(ErrorOf({"model.bodies[0].mass=0"}).find("must be positive (kg), got 0"), std::string::npos);
  // A prismatic joint's coordinate is a length: an angle drive mixes units.
  EXPECT_NE(
      ErrorOf({"model.joints[0].type=PRISMATIC", "model.joints[0].drive={quantity: ANGLE function {constant: 1}}"})
          .find("a prismatic joint's coordinate is a length"),
      std::string::npos);
}

}  // namespace
}  // namespace cosim::smooth
