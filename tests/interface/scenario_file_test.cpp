// Scenario loading: parse errors carry file:line:col, --set overrides follow the scenario
// file's own syntax, and validation messages point back at the place a value came from.
#include "interface/scenario/scenario_file.h"

#include <gtest/gtest.h>

#include <functional>

#include "interface/run/errors.h"
#include "interface/scenario/checks.h"

namespace cosim::interface {
namespace {

const char* kText = R"(name: "t"
model {
  contact_nodes {
    name: "a"
    mass: 2
    position: [0, 0, 1]
  }
  contact_nodes {
    name: "b"
    mass: 3
  }
}
numerics { end_time: 1 step: 0.1 }
coupling { processes { name: "p" } }
)";

std::string MessageOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(ScenarioFile, SyntaxErrorNamesLineAndColumn) {
  // Line 3 has a misspelt field; protobuf's tokenizer reports its 0-based position, which
  // the loader turns into 1-based line:column as editors show it.
  const std::string msg = MessageOf([] { ScenarioFile::Parse("name: \"x\"\nmodel {\n  contact_nodez {}\n}\n", "f.pbtxt", {}); });
  EXPECT_NE(msg.find("f.pbtxt:3:"), std::string::npos) << msg;
  EXPECT_NE(msg.find("contact_nodez"), std::string::npos) << msg;
}

TEST(ScenarioFile, MissingFileIsBadInput) {
  const std::string msg = MessageOf([] { ScenarioFile::Load("/nonexistent/x.pbtxt", {}); });
  EXPECT_NE(msg.find("/nonexistent/x.pbtxt: cannot read"), std::string::npos) << msg;
}

TEST(ScenarioFile, WhereFindsNestedRepeatedFields) {
  // The second node's mass is on line 10, column 5; the first node's position list on line 6.
  const ScenarioFile f = ScenarioFile::Parse(kText, "f.pbtxt", {});
  EXPECT_EQ(f.Where("model.contact_nodes[1].mass"), "f.pbtxt:10:5");
  EXPECT_EQ(f.Where("model.contact_nodes[0].position[2]").substr(0, 10), "f.pbtxt:6:");
  // Absent field: the nearest enclosing field present in the file (node b starts on line 8).
  EXPECT_EQ(f.Where("model.contact_nodes[1].position"), "f.pbtxt:8:3");
}

TEST(ScenarioFile, SetOverridesScalarsListsEnumsAndByName) {
  const ScenarioFile f = ScenarioFile::Parse(
      kText, "f.pbtxt",
      {"numerics.step=0.01", "model.contact_nodes[b].mass=7", "model.contact_nodes[0].position=[1, 2, 3]",
       "model.contact_nodes[0].position[1]=5", "numerics.nonsmooth.lcp.solver=PGS", "name=renamed",
       "coupling.processes[0].contact_nodes=[\"a\", \"b\"]", "coupling.processes[0].contact_nodes[1]=c"});
  EXPECT_DOUBLE_EQ(f.proto().numerics().step(), 0.01);
  EXPECT_DOUBLE_EQ(f.proto().model().contact_nodes(1).mass(), 7.0);
  ASSERT_EQ(f.proto().model().contact_nodes(0).position_size(), 3);
  EXPECT_DOUBLE_EQ(f.proto().model().contact_nodes(0).position(0), 1.0);
  EXPECT_DOUBLE_EQ(f.proto().model().contact_nodes(0).position(1), 5.0);
  EXPECT_EQ(f.proto().numerics().nonsmooth().lcp().solver(), scenario::LcpSettings::PGS);
  EXPECT_EQ(f.proto().name(), "renamed");
  // A list of strings, then one element as a bare word.
  ASSERT_EQ(f.proto().coupling().processes(0).contact_nodes_size(), 2);
  EXPECT_EQ(f.proto().coupling().processes(0).contact_nodes(0), "a");
  EXPECT_EQ(f.proto().coupling().processes(0).contact_nodes(1), "c");
  // A value set by --set is reported at the --set, not in the file.
  EXPECT_EQ(f.Where("model.contact_nodes[1].mass"), "--set model.contact_nodes[b].mass=7");
}

TEST(ScenarioFile, BadOverridesAreReportedWithTheArgument) {
  EXPECT_NE(MessageOf([] { ScenarioFile::Parse(kText, "f", {"numerics.stepp=1"}); }).find("has no field 'stepp'"),
            std::string::npos);
  EXPECT_NE(MessageOf([] { ScenarioFile::Parse(kText, "f", {"model.contact_nodes[c].mass=1"}); })
                .find("none matches [c]"),
            std::string::npos);
  EXPECT_NE(MessageOf([] { ScenarioFile::Parse(kText, "f", {"numerics.step=fast"}); }).find("does not fit"),
            std::string::npos);
  EXPECT_NE(MessageOf([] { ScenarioFile::Parse(kText, "f", {"numerics.step"}); }).find("expected FIELD.PATH=VALUE"),
            std::string::npos);
  EXPECT_NE(MessageOf([] { ScenarioFile::Parse(kText, "f", {"model.contact_nodes.mass=1"}); }).find("is repeated"),
            std::string::npos);
}

TEST(ScenarioFile, ChecksNameFieldValueAndExpectation) {
  const ScenarioFile f = ScenarioFile::Parse(kText, "f.pbtxt", {"model.contact_nodes[0].mass=-1"});
  const Checks checks(f);
  const std::string msg = MessageOf([&] {
    checks.Positive("model.contact_nodes[0].mass", true, f.proto().model().contact_nodes(0).mass(), "kg");
  });
  EXPECT_EQ(msg, "--set model.contact_nodes[0].mass=-1: model.contact_nodes[0].mass: must be positive (kg), got -1");
}

TEST(ScenarioFile, MaterializeDefaultsShowsEverySettingUsed) {
  // Defaults declared in proto/scenario.proto become explicit values, so summary.json lists them.
  scenario::Numerics n;
  MaterializeDefaults(&n);
  EXPECT_TRUE(n.nonsmooth().has_theta());
  EXPECT_DOUBLE_EQ(n.nonsmooth().theta(), 0.5);
  EXPECT_EQ(n.nonsmooth().lcp().solver(), scenario::LcpSettings::LEMKE);
  EXPECT_FALSE(n.has_end_time());  // no default: must be given
}

}  // namespace
}  // namespace cosim::interface
