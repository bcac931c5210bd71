// The launcher's plan of a coupled run's processes (launcher.h): what each process is told.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <string>

#include "interface/launcher/launcher.h"
#include "interface/run/run_driver.h"
#include "interface/scenario/scenario_file.h"

namespace cosim::interface {
namespace {

const std::string kGust = std::string(COSIM_SOURCE_DIR) + "/scenarios/puma/gust.pbtxt";

int EndpointSets(const ProcessPlan& p) {
  return static_cast<int>(std::count_if(p.arguments.begin(), p.arguments.end(), [](const std::string& a) {
    return a.rfind("coupling.processes[", 0) == 0 && a.find("].endpoint=") != std::string::npos;
  }));
}

bool Has(const std::vector<std::string>& list, const std::string& entry) {
  return std::find(list.begin(), list.end(), entry) != list.end();
}

TEST(LauncherPlan, EachContactProcessIsGivenItsOwnEndpointAndOneBlasThread) {
  // Issue 51, item 11: every contact process of an N-blade rotor was given all N endpoints
  // (N overrides to read, and to list in its summary: O(N²) for the run), and OpenBLAS's worker
  // thread spun ~0.1 s of CPU in each of them for LCPs of one node.
  const std::vector<std::string> sets{"patterns[0].count=6"};
  const ScenarioFile file = ScenarioFile::Load(kGust, sets);
  CommandLine cli;
  cli.scenario = kGust;
  cli.out = "/tmp/unused";
  cli.sets = sets;
  std::vector<std::string> arguments{kGust, "--set", sets[0]};
  const char* user = std::getenv("OPENBLAS_NUM_THREADS");
  const std::string saved = user != nullptr ? user : "";
  unsetenv("OPENBLAS_NUM_THREADS");
  const std::vector<ProcessPlan> plan = PlanProcesses(file, cli, arguments, "/tmp/f");
  ASSERT_EQ(plan.size(), 7u);  // six contact processes, then the coordinator
  for (size_t k = 0; k < 6; ++k) {
    EXPECT_EQ(EndpointSets(plan[k]), 1) << plan[k].name;
    EXPECT_TRUE(Has(plan[k].arguments, "coupling.processes[" + std::to_string(k) + "].endpoint=\"ipc:///tmp/f/" +
                                           std::to_string(k) + ".ipc\""))
        << plan[k].name;
    EXPECT_TRUE(Has(plan[k].environment, "OPENBLAS_NUM_THREADS=1")) << plan[k].name;
  }
  EXPECT_EQ(plan[6].program, "smooth_solver");
  EXPECT_EQ(EndpointSets(plan[6]), 6);
  // A user's own setting is theirs.
  setenv("OPENBLAS_NUM_THREADS", "2", 1);
  const std::vector<ProcessPlan> chosen = PlanProcesses(file, cli, arguments, "/tmp/f");
  EXPECT_FALSE(Has(chosen[0].environment, "OPENBLAS_NUM_THREADS=1"));
  if (user != nullptr) {
    setenv("OPENBLAS_NUM_THREADS", saved.c_str(), 1);
  } else {
    unsetenv("OPENBLAS_NUM_THREADS");
  }
}

}  // namespace
}  // namespace cosim::interface
