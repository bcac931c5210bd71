#include "smooth_solver/linear_algebra/klu_solver.h"

#include <klu.h>

#include <utility>
#include <vector>

#include "interface/base/errors.h"
#include "smooth_solver/linear_algebra/klu_ordering.h"

namespace cosim::smooth {

struct KluSolver::Impl {
  klu_common common;
  klu_symbolic* symbolic = nullptr;
  // The other fill-reducing ordering, until the first factorisation has chosen between them.
  klu_symbolic* candidate = nullptr;
  klu_numeric* numeric = nullptr;
  int n = 0;
  // ccolamd's constraint sets, one per column (1: the hub's, ordered last), while analysing.
  std::vector<int> constraint;
};

namespace {

long Fill(const klu_numeric* numeric) { return static_cast<long>(numeric->lnz) + numeric->unz + numeric->nzoff; }

}  // namespace

KluSolver::KluSolver() : impl_(new Impl) { klu_defaults(&impl_->common); }

KluSolver::~KluSolver() {
  Free();
  delete impl_;
}

void KluSolver::Analyze(const Eigen::SparseMatrix<double>& A, const std::vector<int>& last) {
  COSIM_ASSERT(A.isCompressed() && A.rows() == A.cols(), "KLU needs a square compressed matrix");
  Free();
  impl_->n = static_cast<int>(A.rows());
  int* Ap = const_cast<int*>(A.outerIndexPtr());
  int* Ai = const_cast<int*>(A.innerIndexPtr());
  if (!last.empty()) {
    // The hub's columns last (hub_columns.h): each blade's block is eliminated on its own and
    // fills only itself and the hub. L + U of 0.43M, 0.85M and 1.71M entries for Puma gusts of
    // 25, 50 and 100 blades (linear), against 0.63M, 1.56M and 4.36M with COLAMD alone; on
    // the four-blade Puma 67k against 99k (COLAMD) and 73k (AMD).
    OrderColumnsLast(&impl_->common, impl_->n, last, &impl_->constraint);
    impl_->symbolic = klu_analyze(impl_->n, Ap, Ai, &impl_->common);
    impl_->common.ordering = 0;
    impl_->common.btf = 1;
    impl_->common.user_data = nullptr;
    if (impl_->symbolic != nullptr) return;
  }
  // Both of KLU's fill-reducing orderings; the first factorisation keeps the one whose factors
  // are smaller. AMD (on A + Aᵀ, KLU's default) suits the small scenes, but on a saddle-point
  // matrix with a hub joined to every blade its fill grew faster than the model: L + U of 1.7M,
  // 5.1M and 16.8M entries for Puma gusts of 25, 50 and 100 blades, against 1.6M and 4.4M for
  // 50 and 100 with COLAMD (on AᵀA's pattern), which halved the 100-blade run's start.
  impl_->common.ordering = 0;  // AMD
  impl_->symbolic = klu_analyze(impl_->n, Ap, Ai, &impl_->common);
  COSIM_ASSERT(impl_->symbolic != nullptr, "klu_analyze failed");
  impl_->common.ordering = 1;  // COLAMD
  impl_->candidate = klu_analyze(impl_->n, Ap, Ai, &impl_->common);
  impl_->common.ordering = 0;
}

void KluSolver::Free() {
  if (impl_->numeric != nullptr) klu_free_numeric(&impl_->numeric, &impl_->common);
  if (impl_->symbolic != nullptr) klu_free_symbolic(&impl_->symbolic, &impl_->common);
  if (impl_->candidate != nullptr) klu_free_symbolic(&impl_->candidate, &impl_->common);
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
  if (impl_->candidate != nullptr) {  // the first factorisation: the ordering with less fill stays
    klu_numeric* other = klu_factor(Ap, Ai, Ax, impl_->candidate, &impl_->common);
    if (other != nullptr && impl_->common.status == KLU_OK &&
        (impl_->numeric == nullptr || Fill(other) < Fill(impl_->numeric))) {
      std::swap(other, impl_->numeric);
      std::swap(impl_->candidate, impl_->symbolic);
    }
    if (other != nullptr) klu_free_numeric(&other, &impl_->common);
    klu_free_symbolic(&impl_->candidate, &impl_->common);
    if (impl_->numeric != nullptr) impl_->common.status = KLU_OK;
  }

  return impl_->numeric != nullptr && impl_->common.status == KLU_OK;
}

long KluSolver::factor_entries() const { return impl_->numeric != nullptr ? Fill(impl_->numeric) : 0; }

void KluSolver::SolveInPlace(Eigen::Ref<Eigen::VectorXd> b) {
  klu_solve(impl_->symbolic, impl_->numeric, impl_->n, 1, b.data(), &impl_->common);
}

void KluSolver::SolveInPlace(Eigen::MatrixXd& b) {
  COSIM_ASSERT(b.rows() == impl_->n, "KluSolver::SolveInPlace: right-hand sides of the wrong size");
  if (b.cols() == 0) return;
  klu_solve(impl_->symbolic, impl_->numeric, impl_->n, static_cast<int>(b.cols()), b.data(), &impl_->common);
}

}  // namespace cosim::smooth
