// Elastic-body benchmark (not a test): cost of one internal-force (residual) evaluation and
// of one tangent evaluation (with its sparse assembly) for beams of 10, 40 and 160 27-node
// elements (one element across), and of one static Newton solve of the cantilever.
#include <chrono>
#include <cstdio>

#include "smooth_solver/elastic/elastic_body.h"

namespace {

template <typename F>
double Seconds(int repeats, F&& f) {
  const auto t0 = std::chrono::steady_clock::now();
  for (int r = 0; r < repeats; ++r) f();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / repeats;
}

}  // namespace

int main() {
  using namespace cosim::smooth;
  std::printf("%9s %7s %16s %20s %16s\n", "elements", "nodes", "residual [ms]", "tangent+assembly [ms]", "per element [us]");
  for (int n : {10, 40, 160}) {
    ElasticBody body;
    body.Initialize(BeamMesh(1.0 * n / 10.0, 0.2, 0.1, n, 1, 1, {}), ElasticMaterial{1770, 1.792e12, 0.3});
    Eigen::Matrix3Xd x = body.mesh().nodes;
    for (int a = 0; a < x.cols(); ++a) x(1, a) += 1e-4 * x(0, a) * x(0, a);  // a bent shape
    Eigen::VectorXd f;
    Eigen::SparseMatrix<double> K;
    const int repeats = n > 40 ? 5 : 20;
    const double residual = Seconds(repeats, [&] { body.Assemble(x, &f, nullptr); });
    const double tangent = Seconds(repeats, [&] { body.Assemble(x, &f, &K); });
    std::printf("%9d %7d %16.3f %20.3f %16.1f\n", n, body.node_count(), 1e3 * residual, 1e3 * tangent,
                1e6 * tangent / n);
  }
  ElasticBody cantilever;
  cantilever.Initialize(BeamMesh(1.0, 0.2, 0.1, 10, 1, 1, {}), ElasticMaterial{1770, 1.792e12, 0.3});
  const double solve = Seconds(5, [&] {
    SolveStatic(cantilever, cantilever.mesh().root_face, {{cantilever.mesh().tip_centre, Eigen::Vector3d(0, 1e4, 0)}},
                1e-8, 20);
  });
  std::printf("\nstatic cantilever, 10 elements, Newton to 1e-8: %.2f ms\n", 1e3 * solve);
  return 0;
}
