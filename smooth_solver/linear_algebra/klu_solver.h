#pragma once
// Sparse LU by SuiteSparse's KLU for the Newton matrices, whose pattern never changes:
// the ordering (klu_analyze) is computed once; the first factorisation chooses pivots
// (klu_factor) and later ones reuse them (klu_refactor, much cheaper), falling back to a
// fresh klu_factor if the reused pivots give a poor condition estimate. Measured against
// Eigen's SparseLU on the four-bar: see docs/design.md.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <vector>

namespace cosim::smooth {

class KluSolver {
 public:
  KluSolver();
  ~KluSolver();
  KluSolver(const KluSolver&) = delete;
  KluSolver& operator=(const KluSolver&) = delete;

  // Symbolic analysis of A's pattern (compressed, column-major, int indices). `last`: columns
  // the ordering keeps after all others (a hub's: HubColumns); empty, KLU's AMD and COLAMD are
  // both analysed and the first factorisation keeps the one with the smaller factors.
  void Analyze(const Eigen::SparseMatrix<double>& A, const std::vector<int>& last = {});
  // Numeric factorisation; false if A is singular.
  [[nodiscard]] bool Factorize(const Eigen::SparseMatrix<double>& A);
  // Solves A x = b in place.
  void SolveInPlace(Eigen::Ref<Eigen::VectorXd> b);
  // Solves A X = B for the columns of B in place, in one pass over the factors (KLU takes the
  // right-hand sides four at a time: the factors are read once for every four columns).
  void SolveInPlace(Eigen::MatrixXd& b);
  // Entries of the factors L and U (and of the off-diagonal blocks), 0 before the first factorisation.
  long factor_entries() const;
  long full_factorizations() const { return full_; }
  long refactorizations() const { return refactor_; }

 private:
  struct Impl;
  void Free();
  Impl* impl_;
  long full_ = 0, refactor_ = 0;
};

}  // namespace cosim::smooth
