// Rotor benchmark (not a test): the Puma rotor-sailing scenes as a user runs them,
// each alone through cosim_launch (next to this executable), with what a study pays for one:
// wall time per simulated second, its ratio to real time (< 1: faster than real time) and to
// MBDyn's figure for the same rotor (the scene's study.peer, measured on this kind of machine),
// and the co-simulated run's cost over its continuous twin per simulated second.
//
//   rotor_benchmark [--end T] [--set FIELD.PATH=VALUE]...
//
// --end shortens every run to T simulated seconds (default: the whole runs, 50 s engagement and
// 15 s gust: ~10 min); --set is passed to every run (e.g. numerics.step=2e-3). The four-blade
// hex27 hub's step time is elastic_benchmark's (its section 4).
#include <google/protobuf/util/json_util.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "interface/base/errors.h"
#include "interface/scenario/scenario_file.h"
#include "run_summary.pb.h"

namespace {

struct Scene {
  const char* label;
  const char* file;  // under scenarios/puma
};

struct Measured {
  int code = -1;
  cosim::run::RunSummary summary;
};

std::string Quoted(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

Measured Run(const std::string& bin, const std::string& scenario, const std::vector<std::string>& sets,
             const std::string& out) {
  std::string command = bin + "/cosim_launch " + Quoted(scenario) + " --out " + Quoted(out);
  for (const std::string& s : sets) command += " --set " + Quoted(s);
  command += " > " + Quoted(out + ".log") + " 2>&1";
  Measured m;
  const int status = std::system(command.c_str());
  m.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream in(out + "/summary.json");
  std::stringstream text;
  text << in.rdbuf();
  if (!google::protobuf::util::JsonStringToMessage(text.str(), &m.summary).ok()) m.code = -1;
  return m;
}

double Counter(const cosim::run::RunSummary& s, const char* name) {
  const auto it = s.counters().find(name);
  return it == s.counters().end() ? 0.0 : it->second;
}

}  // namespace

int main(int argc, char** argv) {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  std::vector<std::string> sets;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--end" && i + 1 < argc) {
      sets.push_back(std::string("numerics.end_time=") + argv[++i]);
    } else if (a == "--set" && i + 1 < argc) {
      sets.push_back(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: rotor_benchmark [--end T] [--set FIELD.PATH=VALUE]...\n");
      return 2;
    }
  }
  char self[4096];
  const ssize_t n = readlink("/proc/self/exe", self, sizeof(self) - 1);
  if (n <= 0) return 4;
  self[n] = '\0';
  const std::string bin = std::filesystem::path(self).parent_path().string();
  const std::string dir = std::string(COSIM_SOURCE_DIR) + "/scenarios/puma/";
  const std::string scratch = "/tmp/cosim_rotor_bench_" + std::to_string(getpid());

  const Scene pairs[][2] = {{{"engagement, co-simulated", "engage_disengage.pbtxt"},
                             {"engagement, continuous", "engage_disengage_continuous.pbtxt"}},
                            {{"gust, co-simulated", "gust.pbtxt"}, {"gust, continuous", "gust_continuous.pbtxt"}}};
  std::printf("%-26s %4s %9s %9s %9s %10s %10s %9s %8s %8s %8s\n", "run", "exit", "sim [s]", "steps [s]", "wall [s]",
              "wall/sim s", "x realtime", "x MBDyn", "exch/st", "Newt/st", "factors");
  for (const auto& pair : pairs) {
    double per_second[2] = {0.0, 0.0};
    double peer = 0.0;  // MBDyn's wall time per simulated second on this rotor, if the scene names it
    try {
      const cosim::interface::ScenarioFile file = cosim::interface::ScenarioFile::Load(dir + pair[0].file, {});
      const auto& p = file.proto().study().peer();
      if (p.simulated_time() > 0.0) peer = p.wall_time() / p.simulated_time();
    } catch (const cosim::Error& e) {
      std::fprintf(stderr, "%s\n", e.what());
      return 2;
    }
    for (int k = 0; k < 2; ++k) {
      const std::string scenario = dir + pair[k].file;
      const Measured m = Run(bin, scenario, sets, scratch + "_" + std::to_string(k));
      const cosim::run::RunSummary& s = m.summary;
      const double simulated = s.simulated_time() - s.start_time();
      per_second[k] = simulated > 0.0 ? s.wall_time() / simulated : 0.0;
      char versus_peer[32] = "-";
      if (peer > 0.0 && per_second[k] > 0.0)
        std::snprintf(versus_peer, sizeof(versus_peer), "%.1f", peer / per_second[k]);
      std::printf("%-26s %4d %9.3g %9.4g %9.4g %10.3g %10.3g %9s %8.3f %8.3f %8.0f\n", pair[k].label, m.code, simulated,
                  s.step_wall_time(), s.wall_time(), per_second[k], per_second[k] > 0.0 ? 1.0 / per_second[k] : 0.0,
                  versus_peer, s.coupling_iterations().mean_per_step(), s.newton_iterations().mean_per_step(),
                  Counter(s, "newton_factorizations"));
      std::filesystem::remove_all(scratch + "_" + std::to_string(k));
      std::filesystem::remove(scratch + "_" + std::to_string(k) + ".log");
    }
    if (per_second[1] > 0.0) {
      std::printf("%-26s co-simulated / continuous per simulated second: %.2f\n", "", per_second[0] / per_second[1]);
    }
  }
  std::printf(
      "(wall/sim s: the process's wall time per simulated second; x realtime: simulated seconds per wall "
      "second, > 1 is faster than real time (the goal: 2); x MBDyn: how many times faster than MBDyn's "
      "figure for the same rotor in the engagement's study.peer)\n");
  return 0;
}
