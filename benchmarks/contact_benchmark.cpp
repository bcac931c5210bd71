// Contact process benchmark (not a test): cost per Moreau–Jean step, and the bouncing ball
// side by side with Siconos' own kernel (Debian's python3-siconos) in the same run.
//
//   contact_benchmark [--no-peer]
//
// Prints, for the bouncing ball (m = 1, from 1 m, e = 0.9, h = 0.005, θ = 1/2, 10 s): our
// µs per step, the peer's, their ratio, and both final heights (the two implementations run
// the same scheme, so they must agree to round-off). Then the cost per step of 1, 8 and 64
// nodes with two planes each (nodes dropped into V grooves, both contacts active at rest),
// with independent LCPs per node (default) and with one LCP per step over all contacts.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "nonsmooth_solver/integrator/moreau_jean.h"

namespace {

using cosim::nonsmooth::ContactModel;
using cosim::nonsmooth::MoreauJean;
using cosim::nonsmooth::MoreauJeanSettings;

// A scene's contact model and its Moreau–Jean settings (numerics.nonsmooth), as a contact process reads them.
struct Scene {
  ContactModel model;
  MoreauJeanSettings settings;
};

Scene Build(const std::string& text, const std::vector<std::string>& sets = {}) {
  const auto file = cosim::interface::ScenarioFile::Parse(text, "benchmark", sets);
  return {cosim::nonsmooth::BuildContactModel(file), cosim::nonsmooth::ReadMoreauJeanSettings(file)};
}

std::string BallScenario() {
  return R"(model {
    gravity: [0, 0, -9.81]
    obstacles { name: "ground" point: [0, 0, 0] normal: [0, 0, 1] }
    contact_nodes { name: "ball" mass: 1 position: [0, 0, 1] contacts { obstacle: "ground" restitution: 0.9 } }
  }
  numerics { end_time: 10 step: 0.005 })";
}

// `nodes` nodes, each above its own V groove of two planes (±30°), dropped from staggered
// heights with e = 0.5, so contacts open and close at different times.
std::string WedgeScenario(int nodes) {
  std::string model = "model {\n gravity: [0, 0, -9.81]\n";
  for (int i = 0; i < nodes; ++i) {
    const std::string x = std::to_string(3.0 * i);
    model += " obstacles { name: \"l" + std::to_string(i) + "\" point: [" + x +
             ", 0, 0] normal: [0.5, 0, 0.8660254037844386] }\n";
    model += " obstacles { name: \"r" + std::to_string(i) + "\" point: [" + x +
             ", 0, 0] normal: [-0.5, 0, 0.8660254037844386] }\n";
    model += " contact_nodes { name: \"n" + std::to_string(i) + "\" mass: 1 position: [" +
             std::to_string(3.0 * i + 0.05) + ", 0, " + std::to_string(0.2 + 0.01 * i) + "] contacts { obstacle: \"l" +
             std::to_string(i) + "\" restitution: 0.5 } contacts { obstacle: \"r" + std::to_string(i) +
             "\" restitution: 0.5 } }\n";
  }
  return model + "}\nnumerics { end_time: 2 step: 0.001 }\n";
}

// Median over `repeats` runs of the wall time per step [µs] of `steps` steps of size h.
double MicrosecondsPerStep(const Scene& scene, double h, long steps, int repeats, double* final_z) {
  std::vector<double> samples;
  for (int r = 0; r < repeats; ++r) {
    MoreauJean mj(scene.model, scene.settings, 0.0);
    const auto t0 = std::chrono::steady_clock::now();
    for (long k = 0; k < steps; ++k) mj.Step(static_cast<double>(k) * h, h);
    const auto t1 = std::chrono::steady_clock::now();
    samples.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count() / static_cast<double>(steps));
    if (final_z != nullptr) *final_z = mj.positions()(2);
  }
  std::sort(samples.begin(), samples.end());
  return samples[samples.size() / 2];
}

struct PeerResult {
  bool ok = false;
  double us_per_step = 0.0;
  double final_z = 0.0;
};

// Runs the Siconos kernel peer `repeats` times and keeps the median µs per step.
PeerResult RunPeer(int repeats) {
  const std::string script = std::string(COSIM_SOURCE_DIR) + "/benchmarks/siconos_kernel_ball.py";
  std::vector<double> samples;
  PeerResult result;
  for (int r = 0; r < repeats; ++r) {
    const std::string command = "/usr/bin/python3 " + script + " 0.005 10 0.5 2>&1";
    std::FILE* pipe = popen(command.c_str(), "r");
    if (pipe == nullptr) return result;
    char line[512] = {0};
    const bool got = std::fgets(line, sizeof(line), pipe) != nullptr;
    const int status = pclose(pipe);
    long steps = 0;
    double seconds = 0, us = 0, z = 0;
    if (!got || status != 0 ||
        std::sscanf(line, "steps=%ld seconds=%lf us_per_step=%lf final_z=%lf", &steps, &seconds, &us, &z) != 4) {
      std::printf("peer unavailable: %s", got ? line : "no output\n");
      return result;
    }
    samples.push_back(us);
    result.final_z = z;
  }
  std::sort(samples.begin(), samples.end());
  result.ok = true;
  result.us_per_step = samples[samples.size() / 2];
  return result;
}

}  // namespace

int main(int argc, char** argv) {
  const bool peer = !(argc > 1 && std::string(argv[1]) == "--no-peer");
  std::printf("== bouncing ball: m = 1, from 1 m, e = 0.9, h = 0.005, theta = 0.5, 2000 steps ==\n");
  double our_z = 0.0;
  const double ours = MicrosecondsPerStep(Build(BallScenario()), 0.005, 2000, 201, &our_z);
  std::printf("rotor-cosim nonsmooth_solver   %8.3f us/step   final z = %.6e m\n", ours, our_z);
  if (peer) {
    const PeerResult p = RunPeer(7);
    if (p.ok) {
      std::printf("Siconos kernel (python3)       %8.3f us/step   final z = %.6e m\n", p.us_per_step, p.final_z);
      std::printf("speed ratio (peer / ours)      %8.2f x\n", p.us_per_step / ours);
      std::printf("final heights agree to         %8.1e m\n", std::abs(p.final_z - our_z));
    }
  }
  std::printf("\n== nodes in V grooves, two planes each, h = 0.001, 2000 steps ==\n");
  std::printf("%6s %14s %14s %22s\n", "nodes", "us/step", "us/step/node", "one LCP: us/step");
  for (int nodes : {1, 8, 64}) {
    const int repeats = nodes > 8 ? 5 : 21;
    const double us = MicrosecondsPerStep(Build(WedgeScenario(nodes)), 0.001, 2000, repeats, nullptr);
    const double one =
        MicrosecondsPerStep(Build(WedgeScenario(nodes), {"numerics.nonsmooth.split_independent_lcps=false"}), 0.001,
                            2000, repeats, nullptr);
    std::printf("%6d %14.3f %14.3f %22.3f\n", nodes, us, us / nodes, one);
  }
  return 0;
}
