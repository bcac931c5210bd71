// Elastic-body benchmark (not a test): where the time of an elastic Newton iteration goes.
//  1. One 27-node element: internal force alone, force and tangent together (Hex27).
//  2. Beams of 10, 40 and 160 elements (one across): the residual, and the residual with the
//     tangent assembled into the fixed-pattern matrix the CGα integrator factorises (what one
//     Newton iteration pays for the elastic part), and the share of that spent scattering.
//  3. One static Newton solve of the CGα paper's cantilever.
//  4. A four-blade hub (rigid hub on a driven shaft, four blades of ten elements clamped to it,
//     spinning up): cost per CGα step, Newton iterations per step, the share of one elastic
//     force+tangent evaluation in it, and the same run with IDA (tolerances 1e-6) as the peer;
//     then the Newton-matrix levers on the same run (reuse across steps, unrotated
//     and co-rotated with the hub; the element loop on one core and on all), each with its
//     difference from full Newton at the tip and root; then the whole spin-up (0.5 s at
//     h = 1 ms, where the blades flap 8 mm and the centrifugal stiffening grows), full Newton
//     against co-rotated reuse: the first 0.1 s alone flatter the reuse.
//  5. The Puma rotor with four beam blades (scenarios/puma/rotor_no_air.pbtxt) at 5, 10 and 20
//     linear or quadratic elements per blade: cost per CGα step and per element, against the hub.
//  6. The same rotor with and without air (rotor_air.pbtxt against rotor_no_air.pbtxt), and the
//     cost of one call of the air loads' force, tangent and inflow update.
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdio>

#include "smooth_solver/elastic/elastic_body.h"
#include "smooth_solver/elastic/elastic_force.h"
#include "smooth_solver/integrator/cgalpha.h"
#include "smooth_solver/linear_algebra/fixed_pattern_matrix.h"
#include "smooth_solver/simulation/multibody_simulation.h"

namespace {

template <typename F>
double Seconds(int repeats, F&& f) {
  f();  // warm up (first-use allocations)
  const auto t0 = std::chrono::steady_clock::now();
  for (int r = 0; r < repeats; ++r) f();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / repeats;
}

// Wall time per step of `n` steps of length h from t = 0.
double SecondsPerStep(cosim::smooth::MultibodySimulation& sim, int n, double h) {
  const auto t0 = std::chrono::steady_clock::now();
  for (int k = 0; k < n; ++k) sim.Step(k * h, (k + 1) * h - k * h);
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / n;
}

// Discards what it is given (the element work without any scatter).
class NullSink : public cosim::smooth::SparseSink {
 public:
  void Add(int, int, double value) override { sum_ += value; }
  void AddDense(const int*, int count, const double* values, double) override { sum_ += values[count - 1]; }
  double sum_ = 0.0;
};

}  // namespace

int main() {
  using namespace cosim::smooth;
  const ElasticMaterial material{1770, 1.792e12, 0.3};
  {
    ElasticBody one;
    one.Initialize(BeamMesh(0.1, 0.2, 0.1, 1, 1, 1, {}), material);
    Hex27::NodeMatrix x;
    for (int a = 0; a < 27; ++a) x.col(a) = one.mesh().nodes.col(one.mesh().elements[0][static_cast<size_t>(a)]);
    x.row(1) += 1e-4 * x.row(0).array().square().matrix();
    Hex27 e;
    Hex27::NodeMatrix X;
    for (int a = 0; a < 27; ++a) X.col(a) = one.mesh().nodes.col(one.mesh().elements[0][static_cast<size_t>(a)]);
    if (!e.Initialize(X)) {
      std::fprintf(stderr, "elastic_benchmark: the reference element is degenerate\n");
      return 1;
    }
    Hex27::ElementVector f;
    auto K = std::make_unique<Hex27::ElementMatrix>();
    const double force = Seconds(2000, [&] { e.InternalForce(material, x, &f, nullptr); });
    const double tangent = Seconds(200, [&] { e.InternalForce(material, x, &f, K.get()); });
    const double gemm = Seconds(200, [&] { e.MidpointForce(material, X, x, {0.5, 0.0}, &f, K.get()); });
    std::printf("one element: force %.1f us, force + tangent %.1f us (GEMM midpoint %.1f us)\n\n", 1e6 * force,
                1e6 * tangent, 1e6 * gemm);
  }
  std::printf("%9s %7s %14s %26s %14s\n", "elements", "nodes", "residual [ms]", "residual+tangent [ms]",
              "of which scatter");
  for (int n : {10, 40, 160}) {
    ElasticBody body;
    body.Initialize(BeamMesh(1.0 * n / 10.0, 0.2, 0.1, n, 1, 1, {}), material);
    Eigen::Matrix3Xd x = body.mesh().nodes;
    for (int a = 0; a < x.cols(); ++a) x(1, a) += 1e-4 * x(0, a) * x(0, a);  // a bent shape
    const int dofs = 3 * body.node_count();
    Eigen::VectorXd q(dofs);
    Eigen::Map<Eigen::Matrix3Xd>(q.data(), 3, body.node_count()) = x;
    ElasticForce force(&body, 0, 0.0);
    PatternSink pattern;
    force.Pattern(&pattern);
    Eigen::SparseMatrix<double> S = pattern.Build(dofs, dofs);
    Eigen::VectorXd f = Eigen::VectorXd::Zero(dofs);
    const int repeats = n > 40 ? 5 : 20;
    const double residual = Seconds(repeats * 10, [&] { force.AddMidpoint(q, q, 0.5, f, nullptr, 1.0); });
    const double tangent = Seconds(repeats, [&] {
      MatrixSink sink(&S);
      force.AddMidpoint(q, q, 0.5, f, &sink, 1.0);
    });
    const double no_scatter = Seconds(repeats, [&] {
      NullSink sink;
      force.AddMidpoint(q, q, 0.5, f, &sink, 1.0);
    });
    std::printf("%9d %7d %14.3f %26.3f %13.0f%%\n", n, body.node_count(), 1e3 * residual, 1e3 * tangent,
                100.0 * (tangent - no_scatter) / tangent);
  }
  ElasticBody cantilever;
  cantilever.Initialize(BeamMesh(1.0, 0.2, 0.1, 10, 1, 1, {}), material);
  const double solve = Seconds(5, [&] {
    SolveStatic(cantilever, cantilever.mesh().root_face, {{cantilever.mesh().tip_centre, Eigen::Vector3d(0, 1e4, 0)}},
                1e-8, 20);
  });
  std::printf("\nstatic cantilever, 10 elements, Newton to 1e-8: %.2f ms\n", 1e3 * solve);

  // 4. Four-blade hub.
  std::string hub = R"(
    name: "four_blade_hub"
    model {
      gravity: [0, 0, -9.81]
      bodies { name: "hub" mass: 20 inertia: [0.3, 0.3, 0.5] position: [0, 0, 0] }
      joints {
        name: "shaft" type: REVOLUTE body1: "ground" body2: "hub" point: [0, 0, 0] axis: [0, 0, 1]
        drive { quantity: ANGULAR_SPEED function { cosine_ramp { final_value: 30 ramp_time: 0.5 } } }
      })";
  const char* axes[] = {"[1, 0, 0]", "[0, 1, 0]", "[-1, 0, 0]", "[0, -1, 0]"};
  const char* roots[] = {"[0.1, 0, 0]", "[0, 0.1, 0]", "[-0.1, 0, 0]", "[0, -0.1, 0]"};
  for (int b = 0; b < 4; ++b) {
    hub += std::string(R"(
      elastic_bodies {
        name: "blade)") +
           std::to_string(b) + R"("
        material { density: 2700 young: 7e10 poisson: 0.33 }
        beam { length: 1.0 chord: 0.1 thickness: 0.01 elements_along: 10 root: )" +
           roots[b] + " axis: " + axes[b] + R"( }
        clamps { body: "hub" face: "root" }
        retardation_time: 1e-4
      })";
  }
  hub +=
      "\n    }\n    numerics { end_time: 0.1 step: 0.002 }\n"
      "    output {\n"
      "      probes { name: \"tip_z\" quantity: DISPLACEMENT entity: \"blade0\" point: \"tip_centre\" component: Z "
      "frame: \"hub\" }\n"
      "      probes { name: \"tip_y\" quantity: DISPLACEMENT entity: \"blade0\" point: \"tip_centre\" component: Y "
      "frame: \"hub\" }\n"
      "      probes { name: \"root_y\" quantity: REACTION_FORCE entity: \"blade0\" component: Y frame: \"hub\" }\n"
      "    }\n";
  const int steps = 50;
  double hex_step = 0.0;
  std::vector<double> full_newton(3);
  for (const char* integrator : {"CGALPHA", "IDA"}) {
    const auto file = cosim::interface::ScenarioFile::Parse(hub, "four_blade_hub.pbtxt",
                                                            {std::string("numerics.smooth.integrator=") + integrator});
    MultibodySimulation sim(file);
    const double per_step = SecondsPerStep(sim, steps, 0.002);
    const MultibodySystem& sys = sim.system();
    if (std::string(integrator) == "CGALPHA") {
      // One elastic force + tangent evaluation of all four blades into a fixed pattern.
      PatternSink pattern;
      sys.ForcePattern(&pattern);
      Eigen::SparseMatrix<double> S = pattern.Build(sys.coordinates, sys.coordinates);
      Eigen::VectorXd f = Eigen::VectorXd::Zero(sys.coordinates);
      const Eigen::VectorXd& q = sim.integrator().state().q;
      const double elastic = Seconds(5, [&] {
        MatrixSink sink(&S);
        for (const ElasticForce* e : sys.elastic_forces) e->AddMidpoint(q, q, 0.45, f, &sink, 1.0);
      });
      const double iterations = static_cast<double>(sim.newton_iterations()) / steps;
      hex_step = per_step;
      sim.Probe(&full_newton);
      std::printf("\nfour-blade hub (4 × 10 elements, %d coordinates, %d constraints), h = 2 ms:\n", sys.coordinates,
                  sys.constraints.size());
      std::printf(
          "  CGα: %.2f ms per step, %.2f Newton iterations per step; one elastic force+tangent %.2f ms "
          "(%.0f %% of the step)\n",
          1e3 * per_step, iterations, 1e3 * elastic, 100.0 * elastic * iterations / per_step);
    } else {
      std::printf("  IDA (tolerances 1e-6): %.2f ms per output step (%ld internal steps in all)\n", 1e3 * per_step,
                  sim.ida_internal_steps());
    }
  }
  // The Newton-matrix levers on the same 50 steps, against full Newton above: the
  // matrix reused across steps (modified Newton; a reused matrix stops when it contracts less
  // than 4x per iteration), unrotated and co-rotated with the hub (numerics.smooth.jacobian_frame).
  std::printf("  %-44s %10s %8s %9s %14s %14s\n", "Newton matrices", "ms/step", "speed-up", "factor/step",
              "tip_z diff [m]", "root_y diff [N]");
  const std::vector<std::string> co_rotated = {"numerics.smooth.jacobian_max_age=1000",
                                               "numerics.smooth.jacobian_frame=hub"};
  const int cores = omp_get_max_threads();
  struct Lever {
    const char* name;
    std::vector<std::string> sets;
    int threads;
  };
  const Lever levers[] = {
      {"reused up to 20 steps, unrotated", {"numerics.smooth.jacobian_max_age=20"}, cores},
      {"reused, co-rotated, elements on one core", co_rotated, 1},
      {"reused, co-rotated with the hub", co_rotated, cores},
  };
  for (const Lever& lever : levers) {
    omp_set_num_threads(lever.threads);
    MultibodySimulation sim(cosim::interface::ScenarioFile::Parse(hub, "four_blade_hub.pbtxt", lever.sets));
    const double per_step = SecondsPerStep(sim, steps, 0.002);
    std::vector<double> v(3);
    sim.Probe(&v);
    const auto& cg = dynamic_cast<const CgAlpha&>(sim.integrator());
    std::printf("  %-44s %10.2f %7.1fx %9.2f %14.2e %14.2e\n", lever.name, 1e3 * per_step, hex_step / per_step,
                static_cast<double>(cg.factorizations()) / steps, v[0] - full_newton[0], v[2] - full_newton[2]);
  }
  omp_set_num_threads(cores);
  // The whole spin-up at h = 1 ms (at h = 2 ms and ρ∞ = 0.9 Newton fails at t = 0.43 s with
  // either policy: the blades' flap grows with the stiffening, a step-size limit of the scene).
  std::printf("  whole spin-up, 0.5 s at h = 1 ms (%d cores):\n", cores);
  std::vector<double> full(3);
  double full_step = 0.0;
  for (bool reuse : {false, true}) {
    std::vector<std::string> sets = {"numerics.step=0.001"};
    if (reuse) sets.insert(sets.end(), co_rotated.begin(), co_rotated.end());
    MultibodySimulation sim(cosim::interface::ScenarioFile::Parse(hub, "four_blade_hub.pbtxt", sets));
    const int n = 500;
    const double per_step = SecondsPerStep(sim, n, 0.001);
    std::vector<double> v(3);
    sim.Probe(&v);
    const auto& cg = dynamic_cast<const CgAlpha&>(sim.integrator());
    if (!reuse) {
      full = v;
      full_step = per_step;
    }
    std::printf("  %-44s %10.2f %7.1fx %9.2f %14.2e %14.2e\n",
                reuse ? "reused, co-rotated with the hub" : "full Newton", 1e3 * per_step, full_step / per_step,
                static_cast<double>(cg.factorizations()) / n, v[0] - full[0], v[2] - full[2]);
  }
  // The research Puma's articulated rotor with beam blades (scenarios/puma/
  // rotor_no_air.pbtxt: lag and flap hinges, beams clamped at the pitch bearing, lag dampers,
  // gravity, no air) at h = 1e-4 s, against the hex27 hub's CGα step above.
  std::printf("\nPuma rotor, 4 beam blades, CGα at h = 1e-4 s (200 steps from steady spin):\n");
  std::printf("%10s %6s %12s %14s %16s %12s %14s\n", "elements", "nodes", "coordinates", "us per step",
              "us per element", "Newton/step", "hex27 hub / this");
  for (int nodes : {2, 3}) {
    for (int elements : {5, 10, 20}) {
      std::vector<std::string> sets;
      for (int b = 0; b < 4; ++b) {
        const std::string beam = "model.beams[" + std::to_string(b) + "].";
        sets.push_back(beam + "elements=" + std::to_string(elements));
        sets.push_back(beam + "nodes_per_element=" + std::to_string(nodes));
      }
      sets.push_back("output.probes=[]");
      const auto file = cosim::interface::ScenarioFile::Load(
          std::string(COSIM_SOURCE_DIR) + "/scenarios/puma/rotor_no_air.pbtxt", sets);
      MultibodySimulation sim(file);
      const int n = 200;
      const double h = 1e-4;
      sim.Step(0.0, h);  // the start-up step out of the timing
      const long long before = sim.newton_iterations();
      const auto t0 = std::chrono::steady_clock::now();
      for (int k = 1; k <= n; ++k) sim.Step(k * h, h);
      const double per_step = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / n;
      std::printf("%10d %6d %12d %14.0f %16.1f %12.2f %14.1f\n", 4 * elements, nodes, sim.system().coordinates,
                  1e6 * per_step, 1e6 * per_step / (4 * elements),
                  static_cast<double>(sim.newton_iterations() - before) / n, hex_step / per_step);
    }
  }
  // The cost of the air loads on the same rotor (scenarios/puma/rotor_air.pbtxt, strip
  // theory on the four beams with uniform inflow) against the rotor without them, 10 quadratic
  // elements per blade; runs alternated, the median of five of each (the machine is noisy).
  std::printf("\nPuma rotor with and without air (10 × 3-node elements per blade, h = 1e-4 s, 200 steps):\n");
  auto time_rotor = [&](const char* scenario, double* iterations) {
    const auto file =
        cosim::interface::ScenarioFile::Load(std::string(COSIM_SOURCE_DIR) + scenario, {"output.probes=[]"});
    MultibodySimulation sim(file);
    const int n = 200;
    const double h = 1e-4;
    sim.Step(0.0, h);
    const long long before = sim.newton_iterations();
    const auto t0 = std::chrono::steady_clock::now();
    for (int k = 1; k <= n; ++k) sim.Step(k * h, h);
    *iterations = static_cast<double>(sim.newton_iterations() - before) / n;
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / n;
  };
  std::vector<double> with_air, without_air;
  double it_air = 0.0, it_dry = 0.0;
  for (int r = 0; r < 5; ++r) {
    without_air.push_back(time_rotor("/scenarios/puma/rotor_no_air.pbtxt", &it_dry));
    with_air.push_back(time_rotor("/scenarios/puma/rotor_air.pbtxt", &it_air));
  }
  std::sort(with_air.begin(), with_air.end());
  std::sort(without_air.begin(), without_air.end());
  const double wet = with_air[2], dry = without_air[2];
  std::printf(
      "  without air %.0f us per step (%.2f Newton/step), with air %.0f us per step (%.2f Newton/step): "
      "+%.1f %% (goal: at most +20 %%)\n",
      1e6 * dry, it_dry, 1e6 * wet, it_air, 100.0 * (wet / dry - 1.0));
  {
    const auto file = cosim::interface::ScenarioFile::Load(
        std::string(COSIM_SOURCE_DIR) + "/scenarios/puma/rotor_air.pbtxt", {"output.probes=[]"});
    MultibodySimulation sim(file);
    sim.Step(0.0, 1e-4);
    const MultibodySystem& sys = sim.system();
    const AirLoads& air = *sys.air_loads;
    const Eigen::VectorXd& q = sim.integrator().state().q;
    const Eigen::VectorXd& qdot = sim.integrator().state().qdot;
    Eigen::VectorXd f = Eigen::VectorXd::Zero(sys.coordinates);
    struct Null : cosim::smooth::SparseSink {
      void Add(int, int, double v) override { sum += v; }
      double sum = 0.0;
    } sink;
    const int reps = 2000;
    auto t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < reps; ++k) air.AddForce(q, qdot, 0.0, sim.data(), f);
    const double force = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / reps;
    t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < reps; ++k) air.AddTangent(q, qdot, 0.0, sim.data(), 1.0, 0.5, &sink);
    const double tangent = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / reps;
    t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < reps / 10; ++k) air.AcceptStep(q, qdot, 1e-4 * (k + 2), sim.mutable_data());
    const double accept = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / (reps / 10);
    std::printf(
        "  air loads: %zu sections; force %.1f us, force + tangent %.1f us, inflow update %.1f us per call "
        "(checksum %.3g)\n",
        air.section_count(), 1e6 * force, 1e6 * tangent, 1e6 * accept, f.sum() + sink.sum);
  }
  return 0;
}
