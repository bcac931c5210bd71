// The contact process's view of a scenario (contact_view.h): what it keeps is what the whole
// scene says, where the whole scene says it; what it drops is smooth_solver's.
#include <google/protobuf/util/message_differencer.h>
#include <gtest/gtest.h>

#include <string>

#include "interface/base/errors.h"
#include "interface/scenario/scenario_file.h"
#include "nonsmooth_solver/model/contact_model.h"

namespace cosim::interface {
namespace {

using google::protobuf::util::MessageDifferencer;

const std::string kGust = std::string(COSIM_SOURCE_DIR) + "/scenarios/puma/gust.pbtxt";

TEST(ContactView, KeepsEveryContactFieldWhereTheWholeSceneHasIt) {
  // Issue 51, item 11: each contact process of a 200-blade Puma gust expanded all 200 blades'
  // beams (stations, sections) and checked them, 0.44 ms a blade, once per process: O(N²).
  const std::vector<std::string> sets{"patterns[0].count=6", "model.contact_nodes[blade2_stop_node].mass=0.3"};
  const ScenarioFile whole = ScenarioFile::Load(kGust, sets);
  const ScenarioFile view = ScenarioFile::Load(kGust, sets, ScenarioView::kContactProcess);
  const scenario::Model& w = whole.proto().model();
  const scenario::Model& v = view.proto().model();
  // Everything but the smooth model's elements is the whole scene's, element for element, at
  // the same indices (an error names the place in the user's file either way).
  scenario::Model rest_w = w, rest_v = v;
  for (scenario::Model* m : {&rest_w, &rest_v}) {
    m->clear_bodies();
    m->clear_joints();
    m->clear_elastic_bodies();
    m->clear_forces();
    m->clear_beams();
    m->clear_air();
  }
  EXPECT_GT(rest_w.contact_nodes_size(), 0);
  EXPECT_TRUE(MessageDifferencer::Equals(rest_w, rest_v));
  EXPECT_TRUE(MessageDifferencer::Equals(whole.proto().coupling(), view.proto().coupling()));
  EXPECT_TRUE(MessageDifferencer::Equals(whole.proto().output(), view.proto().output()));
  EXPECT_TRUE(MessageDifferencer::Equals(whole.proto().numerics(), view.proto().numerics()));
  EXPECT_EQ(v.contact_nodes(1).mass(), 0.3);  // the override reached the view
  EXPECT_EQ(whole.Where("model.contact_nodes[4].position"), view.Where("model.contact_nodes[4].position"));
  // The smooth model: its names only (the probes of a contact process may name them).
  ASSERT_EQ(v.beams_size(), w.beams_size());
  ASSERT_EQ(v.bodies_size(), w.bodies_size());
  for (int i = 0; i < w.beams_size(); ++i) {
    EXPECT_EQ(v.beams(i).name(), w.beams(i).name());
    EXPECT_EQ(v.beams(i).elements(), w.beams(i).elements());
    EXPECT_EQ(v.beams(i).nodes_per_element(), w.beams(i).nodes_per_element());
    EXPECT_EQ(v.beams(i).stations_size(), 0);
  }
  for (int i = 0; i < w.bodies_size(); ++i) {
    EXPECT_EQ(v.bodies(i).name(), w.bodies(i).name());
    EXPECT_FALSE(v.bodies(i).has_mass());
  }
  ASSERT_EQ(v.air().surfaces_size(), w.air().surfaces_size());
  EXPECT_EQ(v.air().surfaces(0).name(), w.air().surfaces(0).name());
  EXPECT_EQ(v.air().gusts_size(), 0);
  EXPECT_LT(view.proto().ByteSizeLong(), whole.proto().ByteSizeLong() / 4);
}

TEST(ContactView, BuildsTheContactProcessOfTheWholeScene) {
  // The same contact model (nodes, obstacles, probes and which probes are recorded elsewhere)
  // from either view, for each process.
  const std::vector<std::string> sets{"patterns[0].count=3"};
  const ScenarioFile whole = ScenarioFile::Load(kGust, sets);
  const ScenarioFile view = ScenarioFile::Load(kGust, sets, ScenarioView::kContactProcess);
  for (const std::string node : {"blade1_stop_node", "blade3_stop_node"}) {
    const std::set<std::string> only{node};
    const nonsmooth::ContactModel a = nonsmooth::BuildContactModel(whole, &only);
    const nonsmooth::ContactModel b = nonsmooth::BuildContactModel(view, &only);
    ASSERT_EQ(a.nodes.size(), 1u);
    ASSERT_EQ(b.nodes.size(), 1u);
    EXPECT_EQ(a.nodes[0].name, b.nodes[0].name);
    EXPECT_EQ(a.nodes[0].mass, b.nodes[0].mass);
    EXPECT_EQ(a.nodes[0].position, b.nodes[0].position);
    ASSERT_EQ(a.obstacles.size(), b.obstacles.size());
    for (size_t i = 0; i < a.obstacles.size(); ++i) EXPECT_EQ(a.obstacles[i].normal, b.obstacles[i].normal);
    ASSERT_EQ(a.probes.size(), b.probes.size());
    for (size_t i = 0; i < a.probes.size(); ++i) EXPECT_EQ(a.probes[i].name, b.probes[i].name);
  }
}

TEST(ContactView, LeavesTheSmoothModelsOverridesToSmoothSolver) {
  // An override of a beam's station or a body's mass is smooth_solver's: the view, which has no
  // stations, neither applies it nor refuses it. Names and a beam's node count are kept.
  const std::vector<std::string> sets{"patterns[0].count=2",        "model.beams[0].stations[3].mass=20",
                                      "model.bodies[hub].mass=900", "model.air.density=1.0",
                                      "model.beams[1].elements=6",  "model.air.surfaces[0].name=\"renamed\""};
  const ScenarioFile whole = ScenarioFile::Load(kGust, sets);
  const ScenarioFile view = ScenarioFile::Load(kGust, sets, ScenarioView::kContactProcess);
  EXPECT_EQ(whole.proto().model().beams(0).stations(3).mass(), 20.0);
  EXPECT_EQ(view.proto().model().beams(1).elements(), 6);
  EXPECT_FALSE(view.proto().model().air().has_density());
  EXPECT_EQ(view.proto().model().air().surfaces(0).name(), "renamed");  // a kept field of a kept list
  // A bad path is refused by both (the launcher loads the whole scene first).
  EXPECT_THROW(ScenarioFile::Load(kGust, {"model.nothing=1"}, ScenarioView::kContactProcess), cosim::InputError);
}

}  // namespace
}  // namespace cosim::interface
