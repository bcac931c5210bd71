// A rotor's multibody matrices factorised with the hub's columns last (hub_columns.h): the
// factors grow with the blades, and the solves are the ones Eigen's SparseLU gave.
#include <gtest/gtest.h>

#include <Eigen/SparseLU>
#include <string>

#include "interface/scenario/scenario_file.h"
#include "smooth_solver/integrator/cgalpha.h"
#include "smooth_solver/linear_algebra/fixed_pattern_matrix.h"
#include "smooth_solver/linear_algebra/hub_columns.h"
#include "smooth_solver/simulation/multibody_simulation.h"

namespace cosim::smooth {
namespace {

const std::string kGust = std::string(COSIM_SOURCE_DIR) + "/scenarios/puma/gust_continuous.pbtxt";

// [M Φ_qᵀ; Φ_q 0] at the initial positions, as ConsistentAccelerations factorises it.
Eigen::SparseMatrix<double> Saddle(const MultibodySystem& system, const SystemData& data) {
  const int n = system.coordinates, m = system.constraints.size();
  Eigen::SparseMatrix<double> A(n + m, n + m);
  std::vector<Eigen::Triplet<double>> entries;
  struct Sink : SparseSink {
    std::vector<Eigen::Triplet<double>>* out;
    void Add(int r, int c, double v) override { out->emplace_back(r, c, v); }
  } sink;
  sink.out = &entries;
  AddSparse(system.mass, 1.0, &sink);
  system.constraints.Jacobian(data.imposed, system.q0, 0.0, &sink, n, 1.0);
  system.constraints.JacobianTranspose(data.imposed, system.q0, 0.0, &sink, n, 1.0);
  A.setFromTriplets(entries.begin(), entries.end());
  A.makeCompressed();
  return A;
}

TEST(HubFactorization, ARotorsConstrainedMassMatrixFactorisesBladeByBlade) {
  // Issue 51, item 11: the consistent accelerations (every start, release and impact restart)
  // and the impact restarts' projections factorised [M Φ_qᵀ; Φ_q 0] with Eigen's SparseLU and
  // COLAMD, whose factors grow faster than the blades (~7 s of a 200-blade Puma's start). With
  // the hub last, twice the blades give at most 2.1 times the factors, and the solution is
  // SparseLU's to round-off.
  long fill[2] = {0, 0};
  for (int twice = 0; twice < 2; ++twice) {
    const int blades = 8 << twice;
    MultibodySimulation sim(interface::ScenarioFile::Load(kGust, {"patterns[0].count=" + std::to_string(blades)}));
    Eigen::SparseMatrix<double> A = Saddle(sim.system(), sim.data());
    const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(A.rows(), -1.0, 1.0);
    KluSolver lu;
    ASSERT_TRUE(FactorizeHubLast(&A, sim.system().rigid_coordinates(), &lu));
    fill[twice] = lu.factor_entries();
    Eigen::VectorXd x = b;
    lu.SolveInPlace(x);
    Eigen::SparseLU<Eigen::SparseMatrix<double>, Eigen::COLAMDOrdering<int>> reference(A);
    ASSERT_EQ(reference.info(), Eigen::Success);
    const Eigen::VectorXd y = reference.solve(b);
    EXPECT_LT((x - y).norm(), 1e-9 * y.norm()) << blades << " blades";
    EXPECT_LT((A * x - b).norm(), 1e-9 * b.norm()) << blades << " blades";
  }
  std::printf("Puma gust (continuous), [M Φ_qᵀ; Φ_q 0] L + U entries: 8 blades %ld, 16 blades %ld\n", fill[0], fill[1]);
  EXPECT_LE(static_cast<double>(fill[1]), 2.1 * static_cast<double>(fill[0]));
}

TEST(HubFactorization, ASingularMatrixIsSaidToBe) {
  // ConsistentAccelerations reports redundant joints from the factorisation's failure.
  Eigen::SparseMatrix<double> A(3, 3);
  A.insert(0, 0) = 1.0;
  A.insert(1, 1) = 1.0;
  A.insert(2, 1) = 1.0;  // rows 1 and 2 alike, column 2 empty
  A.insert(1, 2) = 0.0;
  KluSolver lu;
  EXPECT_FALSE(FactorizeHubLast(&A, 0, &lu));
}

}  // namespace
}  // namespace cosim::smooth
