#include "smooth_solver/linear_algebra/sun_klu_ordering.h"

#include <ccolamd.h>

#include <algorithm>

namespace cosim::smooth {

namespace {

// KLU's user ordering for SUNDIALS's index type (ccolamd or ccolamd_l to match): 0 on failure,
// else a positive estimate of nnz(L).
sunindextype ConstrainedColamd(sunindextype n, sunindextype Ap[], sunindextype Ai[], sunindextype Perm[],
                               sun_klu_common* common) {
  auto& sets = *static_cast<std::vector<sunindextype>*>(common->user_data);
  const sunindextype nnz = Ap[n];
  if (static_cast<sunindextype>(sets.size()) != n) return 0;
  double knobs[CCOLAMD_KNOBS];
#if defined(SUNDIALS_INT64_T)
  const size_t length = ccolamd_l_recommended(nnz, n, n);
  SuiteSparse_long stats[CCOLAMD_STATS];
  ccolamd_l_set_defaults(knobs);
#else
  const size_t length = ccolamd_recommended(nnz, n, n);
  int stats[CCOLAMD_STATS];
  ccolamd_set_defaults(knobs);
#endif
  if (length == 0) return 0;
  std::vector<sunindextype> rows(length), start(Ap, Ap + n + 1);
  std::copy(Ai, Ai + nnz, rows.begin());
#if defined(SUNDIALS_INT64_T)
  const auto ok =
      ccolamd_l(n, n, static_cast<SuiteSparse_long>(length), rows.data(), start.data(), knobs, stats, sets.data());
#else
  const auto ok = ccolamd(n, n, static_cast<int>(length), rows.data(), start.data(), knobs, stats, sets.data());
#endif
  if (ok == 0) return 0;
  std::copy(start.begin(), start.begin() + n, Perm);
  return std::max<sunindextype>(nnz, 1);
}

}  // namespace

void OrderColumnsLast(sun_klu_common* common, int n, const std::vector<int>& last, std::vector<sunindextype>* sets) {
  if (last.empty()) return;
  sets->assign(static_cast<size_t>(n), 0);
  for (const int j : last) (*sets)[static_cast<size_t>(j)] = 1;
  common->ordering = 3;  // the user's
  common->user_order = ConstrainedColamd;
  common->user_data = sets;
  common->btf = 0;  // (the sets are the matrix's own columns)
}

}  // namespace cosim::smooth
