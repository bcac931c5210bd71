// The coupling iteration's relaxation (interface/coupling/relaxation): on maps whose fixed
// point is known, the iteration counts the methods are built for, and no NaN on a zero or
// stalled residual.
#include "interface/coupling/relaxation.h"

#include <gtest/gtest.h>

#include <Eigen/LU>
#include <cmath>
#include <cstdio>
#include <functional>

namespace cosim::interface {
namespace {

using Map = std::function<Eigen::VectorXd(const Eigen::VectorXd&)>;

// Iterations until |x̃ − x| <= tol (or -1 after 100).
int Solve(Relaxation::Method method, const Map& H, Eigen::VectorXd x, double tol, Eigen::VectorXd* solution) {
  Relaxation relax(method, static_cast<int>(x.size()), 0.5);
  relax.BeginStep();
  Eigen::VectorXd next;
  for (int i = 1; i <= 100; ++i) {
    const Eigen::VectorXd x_tilde = H(x);
    if ((x_tilde - x).norm() <= tol) {
      *solution = x;
      return i;
    }
    relax.Next(x, x_tilde, &next);
    x = next;
  }
  return -1;
}

TEST(Relaxation, LinearMapWhosePlainIterationDivergesIsSolved) {
  // x̃ = A x + b with eigenvalues −1.8, 1.3, 0.5, −0.2 (plain Gauss–Seidel, x ← x̃, diverges).
  // IQN-ILS is a secant method: on a linear map of dimension n it has the exact inverse
  // Jacobian after n + 1 sweeps, so it needs at most n + 2 = 6 evaluations (observed 6).
  // Constant ω = 0.5 turns the eigenvalues into 1 − ω + ωλ = −0.4, 1.15, 0.75, 0.4: it diverges
  // too (1.15); Aitken's single dynamic ω cannot fit all four eigenvalues at once and does not
  // converge in 100 sweeps either (observed) — the case IQN-ILS is for.
  Eigen::Matrix4d Q = Eigen::Matrix4d::Identity();
  Q(0, 1) = 0.3;
  Q(2, 3) = -0.4;
  Q(1, 3) = 0.2;
  const Eigen::Vector4d eigenvalues(-1.8, 1.3, 0.5, -0.2);
  const Eigen::Matrix4d A = Q * eigenvalues.asDiagonal() * Q.inverse();
  const Eigen::Vector4d b(1.0, -2.0, 0.5, 3.0);
  const Eigen::Vector4d exact = (Eigen::Matrix4d::Identity() - A).lu().solve(b);
  const Map H = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd { return A * x + b; };
  Eigen::VectorXd solution;
  const int iqn = Solve(Relaxation::Method::kIqnIls, H, Eigen::Vector4d::Zero(), 1e-10, &solution);
  std::printf("linear 4-D map: IQN-ILS %d evaluations, Aitken %d, constant %d\n", iqn,
              Solve(Relaxation::Method::kAitken, H, Eigen::Vector4d::Zero(), 1e-10, &solution),
              Solve(Relaxation::Method::kConstant, H, Eigen::Vector4d::Zero(), 1e-10, &solution));
  ASSERT_GT(iqn, 0);
  EXPECT_LE(iqn, 6);
  Solve(Relaxation::Method::kIqnIls, H, Eigen::Vector4d::Zero(), 1e-10, &solution);
  EXPECT_LT((solution - exact).norm(), 1e-9);
  EXPECT_EQ(Solve(Relaxation::Method::kConstant, H, Eigen::Vector4d::Zero(), 1e-10, &solution), -1);
  EXPECT_EQ(Solve(Relaxation::Method::kAitken, H, Eigen::Vector4d::Zero(), 1e-10, &solution), -1);
}

TEST(Relaxation, AitkenSolvesAScalarContactLikeMapInFewSweeps) {
  // A stiff scalar interface: x̃ = −k (x − x0) with k = 3 (the reaction a stiff partner returns
  // to an imposed force), plain iteration diverges, ω = 0.5 too (|1 − 0.5·4| = 1). Aitken's
  // secant ω hits the fixed point exactly at its second update on a linear scalar map.
  const Map H = [](const Eigen::VectorXd& x) -> Eigen::VectorXd { return -3.0 * (x.array() - 2.0).matrix(); };
  Eigen::VectorXd solution;
  const int aitken = Solve(Relaxation::Method::kAitken, H, Eigen::VectorXd::Zero(1), 1e-12, &solution);
  ASSERT_GT(aitken, 0);
  EXPECT_LE(aitken, 4);
  EXPECT_NEAR(solution(0), 1.5, 1e-12);  // x = −3 (x − 2)
}

TEST(Relaxation, ZeroAndStalledResidualsStayFinite) {
  for (auto method : {Relaxation::Method::kConstant, Relaxation::Method::kAitken, Relaxation::Method::kIqnIls}) {
    Relaxation relax(method, 3, 0.5);
    relax.BeginStep();
    const Eigen::Vector3d x(1, 2, 3);
    Eigen::VectorXd next;
    relax.Next(x, x, &next);  // already converged
    EXPECT_EQ(next, Eigen::VectorXd(x));
    const Eigen::Vector3d x_tilde(2, 2, 2);
    relax.Next(x, x_tilde, &next);
    relax.Next(x, x_tilde, &next);  // the same sweep again: Δr = 0, Δx̃ = 0
    relax.Next(x, x_tilde, &next);
    EXPECT_TRUE(next.allFinite());
    EXPECT_LT((next - x).norm(), 10.0);
  }
}

TEST(Relaxation, AReusedIqnIlsMemorySavedAndRestoredGoesOnAsTheOriginal) {
  // A restart of a coupled run with IQN-ILS(q) restores the columns of the earlier steps (the
  // coordinator's memory in final_state.pb): the restored relaxation proposes the very x_{i+1} the
  // original does, step after step. A memory of another method or reuse_steps is not restored
  // (the restart's relaxation starts afresh, as its settings say), and one that cannot be a
  // memory of this size is refused with the reason, nothing changed.
  // A linear map x̃ = A x + b of 6 values, 2 sweeps a step: one new column each step.
  Eigen::MatrixXd A(6, 6);
  for (int i = 0; i < 6; ++i) {
    for (int j = 0; j < 6; ++j) A(i, j) = 0.6 * std::sin(6.0 * i + j + 1.0);
  }
  using Vector6d = Eigen::Matrix<double, 6, 1>;
  auto b_of = [](int step) { return Vector6d::LinSpaced(1.0, 1.0 + step); };
  auto sweep = [&](Relaxation* r, const Vector6d& b, Eigen::VectorXd x, int sweeps) {
    Eigen::VectorXd next;
    r->BeginStep();
    for (int i = 0; i < sweeps; ++i) {
      r->Next(x, A * x + b, &next);
      x = next;
    }
    return x;
  };
  Relaxation original(Relaxation::Method::kIqnIls, 6, 0.5, -1, 3);
  for (int step = 0; step < 3; ++step) sweep(&original, b_of(step), Vector6d::Zero(), 2);
  ASSERT_EQ(original.columns(), 3);
  state::RelaxationMemory memory;
  original.Write(&memory);
  Relaxation restored(Relaxation::Method::kIqnIls, 6, 0.5, -1, 3), fresh(Relaxation::Method::kIqnIls, 6, 0.5, -1, 3);
  bool done = false;
  EXPECT_EQ(restored.Read(memory, &done), "");
  EXPECT_TRUE(done);
  EXPECT_EQ(restored.columns(), original.columns());
  for (int step = 3; step < 5; ++step) {
    const Eigen::VectorXd x = sweep(&original, b_of(step), Vector6d::Ones(), 2);
    EXPECT_EQ((sweep(&restored, b_of(step), Vector6d::Ones(), 2) - x).norm(), 0.0) << "step " << step;
    EXPECT_GT((sweep(&fresh, b_of(step), Vector6d::Ones(), 2) - x).norm(), 1e-6) << "step " << step;
  }
  Relaxation other(Relaxation::Method::kIqnIls, 6, 0.5, -1, 1);  // another reuse_steps
  EXPECT_EQ(other.Read(memory, &done), "");
  EXPECT_FALSE(done);
  EXPECT_EQ(other.columns(), 0);
  state::RelaxationMemory truncated = memory;
  truncated.mutable_v()->RemoveLast();
  EXPECT_NE(restored.Read(truncated, &done).find("relaxation memory holds"), std::string::npos);
  state::RelaxationMemory not_finite = memory;
  not_finite.set_w(0, std::nan(""));
  EXPECT_NE(restored.Read(not_finite, &done).find("not finite"), std::string::npos);
  EXPECT_FALSE(done);
}

}  // namespace
}  // namespace cosim::interface
