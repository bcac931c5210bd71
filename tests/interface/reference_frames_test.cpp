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

#include "interface/base/errors.h"
#include "interface/scenario/scenario_file.h"
#include "tests/interface/message_of.h"

namespace cosim::interface {
namespace {

// A three-blade rotor on a tilted shaft, every blade part written in its own frame, the blades
// turned about the shaft: the pattern's axis in the hub's frame.
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
  reference: "hub"
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

// Copy k's turn about z by ψ_k = 0.3 + (k − 1) 2π/3, in the hub's axes (hub ∘ Turn(k)).
Eigen::Isometry3d Turn(int k) {
  return Frame(Vector3d::Zero(), Vector3d(0, 0, 0.3 + (k - 1) * 2 * std::numbers::pi / 3));
}

TEST(ReferenceFrames, PlaceEachPartAsTheComposedTransformations) {
  const ScenarioFile f = ScenarioFile::Parse(kFramed, "framed.pbtxt", {});
  const auto& m = f.proto().model();
  const Eigen::Isometry3d hub = Frame({0.1, 0.2, 2}, {0.05, -0.08, 0});
  auto hinge = [&](int k) { return hub * Turn(k) * Frame({0.4, 0, 0}, Vector3d::Zero()); };
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
    EXPECT_LT((V(tab.position()) - hub * Turn(k) * Vector3d(1, 0, 0)).norm(), 1e-12) << k;
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
        hub * Turn(k) * Frame({0.4, 0, 0}, Vector3d::Zero()) * Frame(Vector3d::Zero(), {0, 0.2, 0});
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

TEST(ReferenceFrames, TheExampleRotorTiltedTurnsItsBladesAboutTheTiltedShaft) {
  // The user guide's example: `--set model.references[hub].rotation=[0, 0.05, 0]` tilts the whole
  // rotor. Each blade k is hub ∘ R_z(ψ_k) ∘ hinge offset, composed here with Eigen: blade 1 (ψ = 0,
  // along +x) goes down by (e + x_g) sin 0.05 and blade 3 up by as much; a turn about the global z
  // after the tilt (the old expansion) put all four down alike, a cone. The flap axes, the
  // surfaces' axes and the rotor's axis follow the tilt.
  const std::string file = std::string(COSIM_SOURCE_DIR) + "/scenarios/examples/hover_rotor_frames/rotor.pbtxt";
  const ScenarioFile f = ScenarioFile::Load(file, {"model.references[hub].rotation=[0, 0.05, 0]"});
  const auto& m = f.proto().model();
  const double e = 0.289, xg = 2.70305676856;
  const Eigen::Isometry3d hub = Frame(Vector3d::Zero(), {0, 0.05, 0});
  ASSERT_EQ(m.bodies_size(), 5);
  for (int k = 1; k <= 4; ++k) {
    const Eigen::Isometry3d hinge =
        hub * Frame(Vector3d::Zero(), {0, 0, (k - 1) * std::numbers::pi / 2}) * Frame({e, 0, 0}, Vector3d::Zero());
    const auto& blade = m.bodies(k);
    ASSERT_EQ(blade.name(), "blade" + std::to_string(k));
    EXPECT_LT((V(blade.position()) - hinge * Vector3d(xg, 0, 0)).norm(), 1e-12) << k;
    EXPECT_LT((Rotation(V(blade.rotation())) - hinge.linear()).norm(), 1e-12) << k;
    EXPECT_LT((V(blade.angular_velocity()) - hinge.linear() * Vector3d(0, 0, -28)).norm(), 1e-12) << k;
    const auto& flap = m.joints(k);
    ASSERT_EQ(flap.name(), "blade" + std::to_string(k) + "_flap");
    EXPECT_LT((V(flap.point()) - hinge.translation()).norm(), 1e-12) << k;
    EXPECT_LT((V(flap.axis()) - hinge.linear() * Vector3d(0, -1, 0)).norm(), 1e-12) << k;
    const auto& surface = m.air().surfaces(k - 1);
    EXPECT_LT((V(surface.axis()) - hinge.linear() * Vector3d::UnitX()).norm(), 1e-12) << k;
    EXPECT_LT((V(surface.chord()) - hinge.linear() * Vector3d(0, -1, 0)).norm(), 1e-12) << k;
    EXPECT_LT((V(surface.upper()) - hinge.linear() * Vector3d::UnitZ()).norm(), 1e-12) << k;
  }
  // Blade 1 down and blade 3 up by (e + x_g) sin 0.05 = 0.1495 m: a tilt, not a cone.
  EXPECT_NEAR(m.bodies(1).position(2), -(e + xg) * std::sin(0.05), 1e-12);
  EXPECT_NEAR(m.bodies(3).position(2), (e + xg) * std::sin(0.05), 1e-12);
  EXPECT_NEAR(m.bodies(2).position(2), 0.0, 1e-12);
  EXPECT_LT((V(m.air().rotors(0).axis()) - hub.linear() * Vector3d::UnitZ()).norm(), 1e-12);
  EXPECT_TRUE(f.warnings().empty());
}

// A two-blade teetering rotor as the new user wrote it: the yoke's frame at its +11° stop,
// outside the pattern, the blades written in it and copied about the shaft.
std::string Teetering(const std::string& pattern_reference) {
  return R"(name: "teeter"
model {
  references { name: "hub" position: [0, 0, 2] }
  references { name: "yoke" reference: "hub" position: [0, 0, -0.1] rotation: [0.19, 0, 0] }
  bodies { name: "yoke" reference: "yoke" mass: 10 inertia: [1, 1, 2] }
}
patterns {
  name: "blades"
  count: 2
  )" + pattern_reference +
         R"(
  each { model {
    references { name: "cuff{k}" reference: "yoke" position: [0.3, 0, 0] rotation: [0.04, 0, 0] }
    bodies { name: "blade{k}" reference: "cuff{k}" position: [3, 0, 0] mass: 50 inertia: [1, 20, 20] }
    joints { name: "pitch{k}" reference: "cuff{k}" type: REVOLUTE body1: "yoke" body2: "blade{k}" point: [0, 0, 0]
             axis: [1, 0, 0] }
  } }
}
)";
}

TEST(ReferenceFrames, ATeeteredYokeTeetersBothBladesAsOneLine) {
  // About the yoke's axis the second blade is the first turned by π in the yoke's frame: the
  // two blades a straight line through the yoke (one tip up, the other down), each pitch axis
  // along its blade. Turned about the global z after the teeter, blade 2 came out up too (a V).
  const ScenarioFile f = ScenarioFile::Parse(Teetering("reference: \"yoke\""), "teeter.pbtxt", {});
  const auto& m = f.proto().model();
  const Eigen::Isometry3d yoke = Frame({0, 0, 2}, Vector3d::Zero()) * Frame({0, 0, -0.1}, {0.19, 0, 0});
  for (int k = 1; k <= 2; ++k) {
    const Eigen::Isometry3d cuff =
        yoke * Frame(Vector3d::Zero(), {0, 0, (k - 1) * std::numbers::pi}) * Frame({0.3, 0, 0}, {0.04, 0, 0});
    EXPECT_LT((V(m.bodies(k).position()) - cuff * Vector3d(3, 0, 0)).norm(), 1e-12) << k;
    EXPECT_LT((V(m.joints(k - 1).axis()) - cuff.linear() * Vector3d::UnitX()).norm(), 1e-12) << k;
  }
  // The blades' centres, the yoke's centre between them.
  const Vector3d c1 = V(m.bodies(1).position()), c2 = V(m.bodies(2).position());
  EXPECT_LT((0.5 * (c1 + c2) - yoke.translation()).norm(), 1e-12);
}

TEST(ReferenceFrames, ACopyOnATiltedFrameTurnedAboutTheGlobalAxisIsRefused) {
  // Without the pattern's reference the copies turn about the global z: on the teetered yoke
  // that is the V above, and on a hub off the axis an orbit about the origin. Refused, naming
  // the frame and what to write.
  const std::string v = MessageOf([] { ScenarioFile::Parse(Teetering(""), "teeter.pbtxt", {}); });
  EXPECT_NE(v.find("teeter.pbtxt:12:"), std::string::npos) << v;
  EXPECT_NE(v.find("frame 'yoke' (rotation [0.19, 0, 0] rad, origin [0, 0, 1.9] m) lies outside pattern "
                   "patterns[0], which turns its copies about the global axis [0, 0, 1]; the frame's axes do not "
                   "keep that axis"),
            std::string::npos)
      << v;
  EXPECT_NE(v.find("Give the pattern `reference: \"yoke\"` and write its axis in that frame"), std::string::npos) << v;
  const std::string off = MessageOf([] {
    ScenarioFile::Parse(
        "model { references { name: \"hub\" position: [5, 0, 0] } }\n"
        "patterns { name: \"p\" count: 2 each { model {\n"
        "  bodies { name: \"b{k}\" reference: \"hub\" position: [1, 0, 0] mass: 1 inertia: [1, 1, 1] }\n} } }\n",
        "f.pbtxt", {});
  });
  EXPECT_NE(off.find("the frame's origin is off that axis"), std::string::npos) << off;
  // With the reference the same scene is two bodies about the hub at x = 5.
  const ScenarioFile on = ScenarioFile::Parse(
      "model { references { name: \"hub\" position: [5, 0, 0] } }\n"
      "patterns { name: \"p\" count: 2 reference: \"hub\" each { model {\n"
      "  bodies { name: \"b{k}\" reference: \"hub\" position: [1, 0, 0] mass: 1 inertia: [1, 1, 1] }\n} } }\n",
      "f.pbtxt", {});
  EXPECT_LT((V(on.proto().model().bodies(0).position()) - Vector3d(6, 0, 0)).norm(), 1e-12);
  EXPECT_LT((V(on.proto().model().bodies(1).position()) - Vector3d(4, 0, 0)).norm(), 1e-12);
  // A pattern's frame inside a copy, or an unknown one, is refused at the pattern's field.
  const std::string unknown = MessageOf([] { ScenarioFile::Parse(Teetering("reference: \"yok\""), "t.pbtxt", {}); });
  EXPECT_NE(unknown.find("patterns[0].reference: 'yok' is not a frame"), std::string::npos) << unknown;
}

}  // namespace
}  // namespace cosim::interface
