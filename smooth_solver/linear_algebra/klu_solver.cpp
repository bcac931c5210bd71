#include "smooth_solver/linear_algebra/klu_solver.h"

#include <klu.h>

#include "interface/run/errors.h"

namespace cosim::smooth {

struct KluSolver::Impl {
  klu_common common;
  klu_symbolic* symbolic = nullptr;
  klu_numeric* numeric = nullptr;
  int n = 0;
};

KluSolver::KluSolver() : impl_(new Impl) { klu_defaults(&impl_->common); }

KluSolver::~KluSolver() {
  if (impl_->numeric != nullptr) klu_free_numeric(&impl_->numeric, &impl_->common);
  if (impl_->symbolic != nullptr) klu_free_symbolic(&impl_->symbolic, &impl_->common);
  delete impl_;
}

void KluSolver::Analyze(const Eigen::SparseMatrix<double>& A) {
  COSIM_ASSERT(A.isCompressed() && A.rows() == A.cols(), "KLU needs a square compressed matrix");
  if (impl_->numeric != nullptr) klu_free_numeric(&impl_->numeric, &impl_->common);
  if (impl_->symbolic != nullptr) klu_free_symbolic(&impl_->symbolic, &impl_->common);
  impl_->n = static_cast<int>(A.rows());
  impl_->symbolic =
      klu_analyze(impl_->n, const_cast<int*>(A.outerIndexPtr()), const_cast<int*>(A.innerIndexPtr()), &impl_->common);
  COSIM_ASSERT(impl_->symbolic != nullptr, "klu_analyze failed");
}

bool KluSolver::Factorize(const Eigen::SparseMatrix<double>& A) {
  int* Ap = const_cast<int*>(A.outerIndexPtr());
  int* Ai = const_cast<int*>(A.innerIndexPtr());
  double* Ax = const_cast<double*>(A.valuePtr());
  if (impl_->numeric != nullptr) {
    // Same pattern, new values: reuse the pivot order, unless it has become poor.
    if (klu_refactor(Ap, Ai, Ax, impl_->symbolic, impl_->numeric, &impl_->common) == 1 &&
        klu_rcond(impl_->symbolic, impl_->numeric, &impl_->common) == 1 && impl_->common.rcond > 1e-12) {
      ++refactor_;
      return true;
    }
    klu_free_numeric(&impl_->numeric, &impl_->common);
  }
  impl_->numeric = klu_factor(Ap, Ai, Ax, impl_->symbolic, &impl_->common);
  ++full_;

  return impl_->numeric != nullptr && impl_->common.status == KLU_OK;
}

void KluSolver::SolveInPlace(Eigen::Ref<Eigen::VectorXd> b) {
  klu_solve(impl_->symbolic, impl_->numeric, impl_->n, 1, b.data(), &impl_->common);
}

void KluSolver::SolveInPlace(Eigen::MatrixXd& b) {
  COSIM_ASSERT(b.rows() == impl_->n, "KluSolver::SolveInPlace: right-hand sides of the wrong size");
  if (b.cols() == 0) return;
  klu_solve(impl_->symbolic, impl_->numeric, impl_->n, static_cast<int>(b.cols()), b.data(), &impl_->common);
}

}  // namespace cosim::smooth
