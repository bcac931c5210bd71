// Smooth-solver benchmark (not a test):
//  1. cost per CGα step of the CGα paper's four-bar (h = 1e-3, tolerance 1e-6, no output),
//     next to the MBDyn figure in docs/reference/peers.md (24 µs/step);
//  2. cost per step of open and closed chains of 10 and 100 bodies (spherical joints), to see
//     how it grows with the number of bodies;
//  2b. the constraint forms of CGα side by side: cost per four-bar step of INDEX3
//     (the paper's), INDEX2_PROJECTED (the default) and the coupled GGL form CGALPHA_INDEX2;
//     on the spinning body (Ωh = 0.3 .. 0.075) and the flat-disc top, the energy change over
//     2 s, the error against the exact spin / IDA, its order, and the cost per step;
//  3. speed against error on the four-bar, CGα against IDA in the same run: error of the
//     positions at t = 2 s against a reference (IDA at tolerance 1e-12), wall time of each
//     run, and the wall time each method needs for errors of 1e-3, 1e-5 and 1e-7
//     (log-log interpolation between runs).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "interface/scenario/checks.h"
#include "smooth_solver/simulation/multibody_simulation.h"

namespace {

using cosim::smooth::DaeState;
using cosim::smooth::MultibodySimulation;

const std::string kFourBar = std::string(COSIM_SOURCE_DIR) + "/scenarios/four_bar.pbtxt";

struct Timed {
  double seconds = 0.0;
  DaeState state;
};

Timed Run(const cosim::interface::ScenarioFile& file, double end, double h) {
  const auto t0 = std::chrono::steady_clock::now();
  MultibodySimulation sim(file);
  for (long k = 0; k < std::lround(end / h); ++k) sim.Step(static_cast<double>(k) * h, h);
  Timed r;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.state = sim.integrator().state();
  return r;
}

// N rods whose joints lie on a circular arc (radius 2 m, ±60°) below its centre, joined by
// spherical joints, the first hung from the ground; closed: the last rod's end is held at
// the ground as well (a sagging cable of links, away from the straight singular shape).
std::string Chain(int n, bool closed) {
  std::string text = "model {\n gravity: [0, 0, -9.81]\n";
  auto point = [n](int i) {
    const double theta = -M_PI / 3 + (2 * M_PI / 3) * i / n;
    return Eigen::Vector3d(2.0 * std::sin(theta), 0.0, -2.0 * std::cos(theta));
  };
  auto vec = [](const Eigen::Vector3d& v) {
    return "[" + cosim::interface::FormatNumber(v.x()) + ", " + cosim::interface::FormatNumber(v.y()) + ", " +
           cosim::interface::FormatNumber(v.z()) + "]";
  };
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d a = point(i), b = point(i + 1), d = b - a;
    const double pitch = -std::atan2(d.z(), d.x());  // rotation about y taking x onto the link
    text += " bodies { name: \"l" + std::to_string(i) +
            "\" mass: 1 inertia: [0.001, 0.02, 0.02] position: " + vec(0.5 * (a + b)) +
            " rotation: " + vec(Eigen::Vector3d(0, pitch, 0)) + " }\n";
  }
  for (int i = 0; i <= (closed ? n : n - 1); ++i) {
    const std::string b1 = i == 0 ? "ground" : "l" + std::to_string(i - 1);
    const std::string b2 = i == n ? "ground" : "l" + std::to_string(i);
    text += " joints { name: \"j" + std::to_string(i) + "\" type: SPHERICAL body1: \"" + b1 + "\" body2: \"" + b2 +
            "\" point: " + vec(point(i)) + " }\n";
  }
  return text + "}\nnumerics { end_time: 1 step: 0.001 }\n";
}

double Interpolate(const std::vector<std::pair<double, double>>& error_time, double target) {
  // error_time sorted by decreasing error; log-log interpolation of time at `target`.
  for (size_t i = 1; i < error_time.size(); ++i) {
    const auto [e0, t0] = error_time[i - 1];
    const auto [e1, t1] = error_time[i];
    if ((e0 - target) * (e1 - target) <= 0.0 && e0 != e1) {
      const double s = (std::log(target) - std::log(e0)) / (std::log(e1) - std::log(e0));
      return std::exp(std::log(t0) + s * (std::log(t1) - std::log(t0)));
    }
  }
  return NAN;
}

}  // namespace

int main() {
  using cosim::interface::ScenarioFile;
  std::printf("== four-bar, CGα, h = 1e-3, tolerance 1e-6, 2000 steps, no output ==\n");
  {
    const Timed r = Run(ScenarioFile::Load(kFourBar, {"numerics.step=0.001"}), 2.0, 1e-3);
    const double us = 1e6 * r.seconds / 2000.0;
    std::printf("rotor-cosim CGα        %8.2f us/step (initial closure included)\n", us);
    std::printf("MBDyn (peers.md)       %8.2f us/step  -> ratio MBDyn/ours %.2f\n", 24.0, 24.0 / us);
  }

  std::printf("\n== chains of rods on spherical joints, CGα, h = 1e-3, 200 steps ==\n");
  std::printf("%8s %8s %14s %14s\n", "bodies", "kind", "us/step", "us/step/body");
  for (int n : {10, 100}) {
    for (bool closed : {false, true}) {
      const ScenarioFile file = ScenarioFile::Parse(Chain(n, closed), "chain", {});
      const Timed r = Run(file, 0.2, 1e-3);
      const double us = 1e6 * r.seconds / 200.0;
      std::printf("%8d %8s %14.2f %14.3f\n", n, closed ? "closed" : "open", us, us / n);
    }
  }

  std::printf("\n== CGα constraint forms ==\n");
  const std::pair<const char*, std::vector<std::string>> forms[] = {
      {"INDEX3 (paper)", {"numerics.smooth.constraint_form=INDEX3"}},
      {"INDEX2_PROJECTED", {"numerics.smooth.constraint_form=INDEX2_PROJECTED"}},
      {"CGALPHA_INDEX2 (GGL)", {"numerics.smooth.integrator=CGALPHA_INDEX2"}}};
  std::printf("four-bar, h = 1e-3, 20000 steps (best of 3):\n");
  double index3_cost = 0.0;
  for (const auto& [name, sets] : forms) {
    std::vector<std::string> all = sets;
    all.push_back("numerics.step=0.001");
    double best = 1e300;
    for (int rep = 0; rep < 3; ++rep) best = std::min(best, Run(ScenarioFile::Load(kFourBar, all), 20.0, 1e-3).seconds);
    const double us = 1e6 * best / 20000.0;
    if (index3_cost == 0.0) index3_cost = us;
    std::printf("  %-22s %8.2f us/step  (%.2f x INDEX3)\n", name, us, us / index3_cost);
  }
  const std::string hard = std::string(COSIM_SOURCE_DIR) + "/scenarios/hard/";
  std::printf("spinning body (150 rad/s, exact: steady spin) and flat-disc top (IDA 1e-11), 2 s:\n");
  std::printf("  %-22s %-8s %10s %14s %12s %10s\n", "form", "h", "Ωh", "energy change", "error", "us/step");
  for (const auto& [name, sets] : forms) {
    for (const char* scene : {"spinning_body", "flat_disc_top"}) {
      std::vector<double> errors;
      DaeState exact;
      if (std::string(scene) == "flat_disc_top") {
        exact = Run(ScenarioFile::Load(hard + scene + ".pbtxt", {"numerics.smooth.integrator=IDA",
                                                                 "numerics.smooth.ida_relative_tolerance=1e-11",
                                                                 "numerics.smooth.ida_absolute_tolerance=1e-11"}),
                    2.0, 0.01)
                    .state;
      }
      for (double h : {2e-3, 1e-3, 5e-4}) {
        std::vector<std::string> all = sets;
        all.push_back("numerics.step=" + cosim::interface::FormatNumber(h));
        all.push_back("numerics.smooth.watchdog.rigidity_rate=0");  // measure the blow-up, do not stop it
        all.push_back("numerics.smooth.watchdog.energy_growth=0");
        const ScenarioFile file = ScenarioFile::Load(hard + scene + ".pbtxt", all);
        double e0 = 0.0, e1 = 0.0, seconds = 0.0, error = NAN;
        try {
          const auto t0 = std::chrono::steady_clock::now();
          MultibodySimulation sim(file);
          const auto energy = [&] {
            const DaeState& st = sim.integrator().state();
            return sim.system().KineticEnergy(st.qdot) + sim.system().PotentialEnergy(st.q);
          };
          e0 = energy();
          for (long k = 0; k < std::lround(2.0 / h); ++k) sim.Step(static_cast<double>(k) * h, h);
          seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
          e1 = energy();
          const Eigen::VectorXd& q = sim.integrator().state().q;
          if (std::string(scene) == "spinning_body") {
            const Eigen::Vector3d u(std::cos(300.0), 0, -std::sin(300.0));  // 150 rad/s × 2 s
            error = (q.segment<3>(3) - u).norm();
          } else {
            error = (q.head<3>() - exact.q.head<3>()).norm();
          }
        } catch (const std::exception& e) {
          std::printf("  %-22s %-8.0e failed: %.60s\n", name, h, e.what());
          continue;
        }
        errors.push_back(error);
        std::printf("  %-22s %-8.0e %10.3f %+13.2e%% %12.3e %10.2f  %s\n", name, h, 150.0 * h, 100.0 * (e1 - e0) / e0,
                    error, 1e6 * seconds / (2.0 / h), scene);
      }
      if (errors.size() == 3) {
        std::printf("  %-22s order %.2f (%s)\n", name, std::log2(errors[0] / errors[2]) / 2.0, scene);
      }
    }
  }

  std::printf("\n== speed against error, four-bar positions at t = 2 s (reference: IDA, tol 1e-12) ==\n");
  const auto ida_set = [](double tol) {
    return std::vector<std::string>{"numerics.smooth.integrator=IDA",
                                    "numerics.smooth.ida_relative_tolerance=" + cosim::interface::FormatNumber(tol),
                                    "numerics.smooth.ida_absolute_tolerance=" + cosim::interface::FormatNumber(tol)};
  };
  const DaeState reference = Run(ScenarioFile::Load(kFourBar, ida_set(1e-12)), 2.0, 0.01).state;
  std::vector<std::pair<double, double>> cg, ida;
  std::printf("%-24s %12s %12s\n", "run", "error", "wall [s]");
  for (double h : {4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4, 1.25e-4, 6.25e-5, 3.125e-5, 1.5625e-5}) {
    const Timed r = Run(ScenarioFile::Load(kFourBar, {"numerics.smooth.newton_tolerance=1e-11"}), 2.0, h);
    const double e = (r.state.q - reference.q).lpNorm<Eigen::Infinity>();
    cg.emplace_back(e, r.seconds);
    std::printf("CGα h = %-16.2e %12.3e %12.4f\n", h, e, r.seconds);
  }
  for (double tol : {1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11}) {
    // Output every 0.01 s: IDA steps on its own between outputs.
    const Timed r = Run(ScenarioFile::Load(kFourBar, ida_set(tol)), 2.0, 0.01);
    const double e = (r.state.q - reference.q).lpNorm<Eigen::Infinity>();
    ida.emplace_back(e, r.seconds);
    std::printf("IDA tol = %-14.0e %12.3e %12.4f\n", tol, e, r.seconds);
  }
  std::printf("\n%10s %14s %14s %10s\n", "error", "CGα [s]", "IDA [s]", "IDA/CGα");
  for (double target : {1e-3, 1e-5, 1e-7}) {
    const double a = Interpolate(cg, target), b = Interpolate(ida, target);
    std::printf("%10.0e %14.4f %14.4f %10.2f\n", target, a, b, b / a);
  }
  return 0;
}
