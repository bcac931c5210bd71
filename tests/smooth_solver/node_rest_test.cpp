// Whether a contact node can rest where a coupled scene starts it, under the force a settled
// smooth model exerts on it (simulation/node_rest.h): Signorini's frictionless plane pushes along
// its normal and never pulls; Coulomb's cone holds a tangential part up to μ times the push.
#include "smooth_solver/simulation/node_rest.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "interface/base/errors.h"
#include "interface/scenario/checks.h"
#include "interface/scenario/scenario_file.h"

namespace cosim::smooth {
namespace {

// A 1 kg node on a floor z >= 0 and against a wall x >= 0 of a wedge, with no smooth model
// behind it: the checks need only the scenario for their messages.
const interface::ScenarioFile& File() {
  static const interface::ScenarioFile file =
      interface::ScenarioFile::Parse(R"(name: "rest" model { gravity: [0, 0, -9.81] })", "rest.pbtxt", {});
  return file;
}

RestingNode NodeOnFloor(double friction = 0.0) {
  RestingNode node;
  node.node = "pad";
  node.path = "model.contact_nodes[0]";
  node.load = Eigen::Vector3d(0.0, 0.0, -9.81);
  RestingNode::Plane floor;
  floor.obstacle = "floor";
  floor.normal = Eigen::Vector3d::UnitZ();
  floor.friction = friction;
  node.planes.push_back(floor);
  RestingNode::Plane wall;  // 1 cm away: not touching
  wall.obstacle = "wall";
  wall.normal = Eigen::Vector3d::UnitX();
  wall.gap = 0.01;
  node.planes.push_back(wall);
  return node;
}

std::string Refusal(const RestingNode& node, const Eigen::Vector3d& force) {
  try {
    CheckNodesRest(interface::Checks(File()), {node}, {force});
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(NodeRest, APushAlongTheNormalRestsAPullOrASlideDoesNot) {
  // Pressed down by 100 N on the floor: the floor pushes back 109.81 N. Accepted.
  EXPECT_EQ(Refusal(NodeOnFloor(), Eigen::Vector3d(0, 0, -100)), "");
  // Pulled up by 100 N: the floor would have to pull (−90.19 N): refused, naming the node.
  const std::string lift = Refusal(NodeOnFloor(), Eigen::Vector3d(0, 0, 100));
  EXPECT_NE(lift.find("numerics.smooth.settle: contact node 'pad' (model.contact_nodes[0])"), std::string::npos)
      << lift;
  EXPECT_NE(lift.find("the smooth model lifts it off"), std::string::npos) << lift;
  // Pushed sideways by 5 N along the floor: a frictionless floor cannot hold it (the wall,
  // 1 cm away, does not touch); with μ = 0.5 the cone holds 0.5 × 109.81 N.
  const std::string slide = Refusal(NodeOnFloor(), Eigen::Vector3d(-5, 0, -100));
  EXPECT_NE(slide.find("the planes it touches ('floor')"), std::string::npos) << slide;
  EXPECT_NE(slide.find("along no plane's normal, [-5, 0, 0] N, would move it"), std::string::npos) << slide;
  EXPECT_EQ(Refusal(NodeOnFloor(0.5), Eigen::Vector3d(-5, 0, -100)), "");
  EXPECT_NE(Refusal(NodeOnFloor(0.01), Eigen::Vector3d(-5, 0, -100)).find("more than friction holds"),
            std::string::npos);
  // At the wall (gap within 1e-6 m) the same sideways push rests on both planes.
  RestingNode corner = NodeOnFloor();
  corner.planes[1].gap = 5e-7;
  EXPECT_EQ(Refusal(corner, Eigen::Vector3d(-5, 0, -100)), "");
  // Started 1 mm inside the floor: refused at its position.
  RestingNode inside = NodeOnFloor();
  inside.planes[0].gap = -1e-3;
  EXPECT_NE(Refusal(inside, Eigen::Vector3d(0, 0, -100)).find("model.contact_nodes[0].position"), std::string::npos);
  // In mid-air (both planes away) any force but one balancing its load moves it.
  RestingNode air = NodeOnFloor();
  air.planes[0].gap = 0.02;
  EXPECT_NE(Refusal(air, Eigen::Vector3d(0, 0, -100)).find("it touches no plane"), std::string::npos);
  EXPECT_EQ(Refusal(air, Eigen::Vector3d(0, 0, 9.81)), "");
}

TEST(NodeRest, ANodeThatMustMoveSlidesAlongItsPlanesOrHangsFree) {
  // A node the settle lets move (it cannot rest where it starts) moves in the directions its
  // planes leave free: two on the floor, one along the edge of floor and wall, three in mid-air.
  RestingNode node = NodeOnFloor();
  node.position = Eigen::Vector3d(0.01, 0.0, 0.0);  // on the floor, 1 cm from the wall (gap as drawn)
  node.planes[1].point = Eigen::Vector3d::Zero();
  const Eigen::MatrixXd floor = FreeDirections(node, {0});
  ASSERT_EQ(floor.cols(), 2);
  EXPECT_NEAR((floor.transpose() * Eigen::Vector3d::UnitZ()).norm(), 0.0, 1e-15);
  EXPECT_NEAR((floor.transpose() * floor - Eigen::Matrix2d::Identity()).norm(), 0.0, 1e-15);
  const Eigen::MatrixXd edge = FreeDirections(node, {0, 1});
  ASSERT_EQ(edge.cols(), 1);
  EXPECT_NEAR(std::abs(edge(1, 0)), 1.0, 1e-15);  // along y, the edge
  EXPECT_EQ(FreeDirections(node, {}).cols(), 3);
  // Put on both planes it goes to the edge, the nearest point of both; its gaps follow a move,
  // and its load follows through its stiffness (an anchor spring of 100 N/m here).
  EXPECT_NEAR((OnPlanes(node, {0, 1}) - Eigen::Vector3d::Zero()).norm(), 0.0, 1e-15);
  node.stiffness = -100.0 * Eigen::Matrix3d::Identity();
  node.MoveTo(Eigen::Vector3d(0.02, 0.0, 0.005));
  EXPECT_TRUE(node.moved);
  EXPECT_NEAR(node.planes[0].gap, 0.005, 1e-15);
  EXPECT_NEAR(node.planes[1].gap, 0.02, 1e-15);
  EXPECT_NEAR((node.load - Eigen::Vector3d(-1.0, 0.0, -9.81 - 0.5)).norm(), 0.0, 1e-12);
  // A moved node that cannot rest is refused where the settle put it, not where it started.
  const std::string refusal = Refusal(node, Eigen::Vector3d(0, 0, -100));
  EXPECT_NE(refusal.find("cannot rest where the settle moved it"), std::string::npos) << refusal;
  EXPECT_NE(refusal.find("it touches no plane to hold it: that force would move it"), std::string::npos) << refusal;
  EXPECT_NE(refusal.find("would move it. Remove settle"), std::string::npos) << refusal;
}

}  // namespace
}  // namespace cosim::smooth
