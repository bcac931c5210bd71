// Reference frames (proto Reference): a rotor written as an MBDyn user writes it — the hub's
// frame, each blade's hinge frame relative to it, the drooped frame relative to the hinge — is
// placed exactly as the composition of those rigid transformations, computed here independently
// with Eigen; and mistakes in frames are refused naming their place.
#include <google/protobuf/util/field_comparator.h>
#include <google/protobuf/util/message_differencer.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <functional>
#include <numbers>
#include <string>

#include "interface/run/errors.h"
#include "interface/scenario/scenario_file.h"
#include "tests/interface/message_of.h"

namespace cosim::interface {
namespace {

// A three-blade rotor on a tilted shaft, every blade part written in its own frame.
const char* kFramed = R"(name: "framed"
model {
  references { name: "hub" position: [0.1, 0.2, 2] rotation: [0.05, -0.08, 0] }
  bodies { name: "hub" reference: "hub" mass: 10 inertia: [1, 1, 2] }
  obstacles { name: "deck" reference: "hub" point: [0, 0, -1] normal: [0, 0, 1] }
  joints { name: "link" reference: "hinge2" type: SPHERICAL body1: "hub" body2: "blade2" point: [0.1, 0, 0] }
}
patterns {
  name: "blades"
  count: 3
  first_azimuth: 0.3
  each {
    model {
      references { name: "hinge{k}" reference: "hub" position: [0.4, 0, 0] }
      references { name: "droop{k}" reference: "hinge{k}" rotation: [0, 0.1, 0] }
      bodies { name: "blade{k}" reference: "droop{k}" position: [3, 0, 0.02] mass: 50 inertia: [1, 20, 20]
               velocity: [0, 30, 0] }
      joints { name: "flap{k}" reference: "hinge{k}" type: REVOLUTE body1: "hub" body2: "blade{k}"
               point: [0, 0, 0] axis: [0, -1, 0] point1: [0.4, 0, 0] }
      bodies { name: "tab{k}" reference: "hub" position: [1, 0, 0] mass: 1 inertia: [1, 1, 1] }
    }
  }
}
)";

using Eigen::Vector3d;

Eigen::Matrix3d Rotation(const Vector3d& v) {
  return v.norm() > 0 ? Eigen::AngleAxisd(v.norm(), v.normalized()).toRotationMatrix() : Eigen::Matrix3d::Identity();
}

Eigen::Isometry3d Frame(const Vector3d& position, const Vector3d& rotation) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Rotation(rotation);
  T.translation() = position;
  return T;
}

Vector3d V(const google::protobuf::RepeatedField<double>& v) { return Vector3d(v[0], v[1], v[2]); }

// Copy k's turn about z by ψ_k = 0.3 + (k − 1) 2π/3.
Eigen::Isometry3d Turn(int k) {
  return Frame(Vector3d::Zero(), Vector3d(0, 0, 0.3 + (k - 1) * 2 * std::numbers::pi / 3));
}

TEST(ReferenceFrames, PlaceEachPartAsTheComposedTransformations) {
  const ScenarioFile f = ScenarioFile::Parse(kFramed, "framed.pbtxt", {});
  const auto& m = f.proto().model();
  const Eigen::Isometry3d hub = Frame({0.1, 0.2, 2}, {0.05, -0.08, 0});
  auto hinge = [&](int k) { return Turn(k) * hub * Frame({0.4, 0, 0}, Vector3d::Zero()); };
  auto droop = [&](int k) { return hinge(k) * Frame(Vector3d::Zero(), {0, 0.1, 0}); };
  // Expanded order: hub, then per copy blade{k} and tab{k}.
  ASSERT_EQ(m.bodies_size(), 7);
  EXPECT_LT((V(m.bodies(0).position()) - hub.translation()).norm(), 1e-12);
  EXPECT_LT((Rotation(V(m.bodies(0).rotation())) - hub.linear()).norm(), 1e-12);  // left out: the frame's
  for (int k = 1; k <= 3; ++k) {
    const auto& blade = m.bodies(2 * k - 1);
    const auto& tab = m.bodies(2 * k);
    const auto& flap = m.joints(k);
    ASSERT_EQ(blade.name(), "blade" + std::to_string(k));
    EXPECT_FALSE(blade.has_reference());  // resolved: every reader sees global coordinates
    EXPECT_LT((V(blade.position()) - droop(k) * Vector3d(3, 0, 0.02)).norm(), 1e-12) << k;
    EXPECT_LT((Rotation(V(blade.rotation())) - droop(k).linear()).norm(), 1e-12) << k;
    EXPECT_LT((V(blade.velocity()) - droop(k).linear() * Vector3d(0, 30, 0)).norm(), 1e-12) << k;
    EXPECT_LT((V(tab.position()) - Turn(k) * hub * Vector3d(1, 0, 0)).norm(), 1e-12) << k;
    EXPECT_LT((V(flap.point()) - hinge(k).translation()).norm(), 1e-12) << k;
    EXPECT_LT((V(flap.axis()) - hinge(k).linear() * Vector3d(0, -1, 0)).norm(), 1e-12) << k;
    EXPECT_EQ(V(flap.point1()), Vector3d(0.4, 0, 0));  // a body-frame offset stays as written
    // The frames themselves end global, for a reader that wants them (the expanded scenario).
    const auto& frame = m.references(1 + 2 * (k - 1));
    ASSERT_EQ(frame.name(), "hinge" + std::to_string(k));
    EXPECT_LT((V(frame.position()) - hinge(k).translation()).norm(), 1e-12);
    EXPECT_LT((Rotation(V(frame.rotation())) - hinge(k).linear()).norm(), 1e-12);
  }
  // An element outside the pattern written in a copy's frame; a plane in the hub's.
  EXPECT_LT((V(m.joints(0).point()) - hinge(2) * Vector3d(0.1, 0, 0)).norm(), 1e-12);
  EXPECT_LT((V(m.obstacles(0).point()) - hub * Vector3d(0, 0, -1)).norm(), 1e-12);
  EXPECT_LT((V(m.obstacles(0).normal()) - hub.linear() * Vector3d::UnitZ()).norm(), 1e-12);
}

TEST(ReferenceFrames, AnOverrideOfAFrameMovesEverythingWrittenInIt) {
  // The frames are resolved after the overrides: raising the hub raises the blades, and a
  // template's droop frame changes every copy's droop.
  const ScenarioFile f = ScenarioFile::Parse(
      kFramed, "framed.pbtxt",
      {"model.references[hub].position=[0, 0, 3]", "patterns[0].each.model.references[1].rotation=[0, 0.2, 0]"});
  const Eigen::Isometry3d hub = Frame({0, 0, 3}, {0.05, -0.08, 0});
  for (int k = 1; k <= 3; ++k) {
    const Eigen::Isometry3d droop =
        Turn(k) * hub * Frame({0.4, 0, 0}, Vector3d::Zero()) * Frame(Vector3d::Zero(), {0, 0.2, 0});
    EXPECT_LT((V(f.proto().model().bodies(2 * k - 1).position()) - droop * Vector3d(3, 0, 0.02)).norm(), 1e-12);
  }
  EXPECT_TRUE(f.warnings().empty());
}

TEST(ReferenceFrames, MistakesNameTheirPlace) {
  auto load = [](const std::string& text) { return MessageOf([&] { ScenarioFile::Parse(text, "f.pbtxt", {}); }); };
  const std::string body = "  bodies { name: \"b\" mass: 1 inertia: [1, 1, 1] reference: \"hbu\" }\n";
  const std::string unknown = load("model {\n  references { name: \"hub\" }\n" + body + "}\n");
  EXPECT_NE(unknown.find("f.pbtxt:3:"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("model.bodies[0].reference: 'hbu' is not a frame; model.references defines hub"),
            std::string::npos)
      << unknown;
  const std::string cycle = load(
      "model {\n  references { name: \"a\" reference: \"b\" }\n  references { name: \"b\" reference: \"c\" }\n"
      "  references { name: \"c\" reference: \"a\" }\n}\n");
  EXPECT_NE(cycle.find("frames placed relative to each other in a cycle: a → b → c → a"), std::string::npos) << cycle;
  EXPECT_NE(cycle.find("f.pbtxt:2:"), std::string::npos) << cycle;
  const std::string twice = load("model {\n  references { name: \"a\" }\n  references { name: \"a\" }\n}\n");
  EXPECT_NE(twice.find("f.pbtxt:3:"), std::string::npos) << twice;
  EXPECT_NE(twice.find("'a' names model.references[0] already"), std::string::npos) << twice;
  const std::string nameless = load("model {\n  references { position: [1, 0, 0] }\n}\n");
  EXPECT_NE(nameless.find("model.references[0].name: missing"), std::string::npos) << nameless;
  const std::string short_position = load("model {\n  references { name: \"a\" position: [1, 0] }\n}\n");
  EXPECT_NE(short_position.find("model.references[0].position: expected [x, y, z], got 2 values"), std::string::npos)
      << short_position;
  // In a pattern's copy the place is the template's line, with the copy.
  const std::string in_copy = load(
      "patterns { name: \"p\" count: 2 each { model {\n"
      "  bodies { name: \"b{k}\" mass: 1 inertia: [1, 1, 1] reference: \"h{k}\" }\n} } }\n");
  EXPECT_NE(in_copy.find("f.pbtxt:2:"), std::string::npos) << in_copy;
  EXPECT_NE(in_copy.find("(copy 1 of pattern 'p')"), std::string::npos) << in_copy;
  EXPECT_NE(in_copy.find("'h1' is not a frame; model.references defines none"), std::string::npos) << in_copy;
}

TEST(ReferenceFrames, TheExampleRotorExpandsToTheHandWrittenOne) {
  // scenarios/examples/hover_rotor_frames (parameters, a frame per blade, the blade included once
  // into a pattern, its aerodynamic stations from a CSV) is scenarios/aero/hover_rotor.pbtxt
  // written without trigonometry: the two expanded models agree in every field, numbers within
  // 1e-9 (the hand-written file has 12 digits).
  const std::string scenarios = std::string(COSIM_SOURCE_DIR) + "/scenarios";
  const ScenarioFile framed = ScenarioFile::Load(scenarios + "/examples/hover_rotor_frames/rotor.pbtxt", {});
  const ScenarioFile by_hand = ScenarioFile::Load(scenarios + "/aero/hover_rotor.pbtxt", {});
  scenario::Model a = framed.proto().model(), b = by_hand.proto().model();
  EXPECT_EQ(a.references_size(), 5);  // the hub's and four hinges, now global
  a.clear_references();
  // The hub's left-out position and rotation become its frame's (here the global origin's),
  // written out; the hand-written hub leaves them to their defaults, the same zeros.
  for (int i = 0; i < 3; ++i) {
    b.mutable_bodies(0)->add_position(0.0);
    b.mutable_bodies(0)->add_rotation(0.0);
  }
  google::protobuf::util::DefaultFieldComparator comparator;
  comparator.set_float_comparison(google::protobuf::util::DefaultFieldComparator::APPROXIMATE);
  comparator.SetDefaultFractionAndMargin(0.0, 1e-9);
  google::protobuf::util::MessageDifferencer differencer;
  differencer.set_field_comparator(&comparator);
  std::string differences;
  differencer.ReportDifferencesToString(&differences);
  EXPECT_TRUE(differencer.Compare(a, b)) << differences;
  EXPECT_EQ(a.bodies_size(), 5);
  EXPECT_EQ(a.air().surfaces(3).stations_size(), 2);
  // A five-blade variant is one parameter.
  const ScenarioFile five =
      ScenarioFile::Load(scenarios + "/examples/hover_rotor_frames/rotor.pbtxt", {"parameters[blades].value=5"});
  EXPECT_EQ(five.proto().model().bodies_size(), 6);
  EXPECT_EQ(five.proto().model().air().rotors(0).surfaces_size(), 5);
}

}  // namespace
}  // namespace cosim::interface
