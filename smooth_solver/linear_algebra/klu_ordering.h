#pragma once
// KLU with chosen columns ordered after all others (a hub's: hub_columns.h), by COLAMD
// constrained with SuiteSparse's ccolamd as KLU's user ordering. For KluSolver's klu_common
// (int indices) and SUNDIALS's sun_klu_common (KINSOL's consistent initial state; klu_l_common
// with 64-bit indices) alike.
#include <ccolamd.h>
#include <klu.h>

#include <algorithm>
#include <vector>

namespace cosim::smooth {

namespace klu_ordering {

// ccolamd for either index type.
inline size_t Recommended(int nnz, int n) { return ccolamd_recommended(nnz, n, n); }
inline size_t Recommended(SuiteSparse_long nnz, SuiteSparse_long n) { return ccolamd_l_recommended(nnz, n, n); }
inline bool Order(int n, size_t length, int* rows, int* start, int* sets) {
  double knobs[CCOLAMD_KNOBS];
  int stats[CCOLAMD_STATS];
  ccolamd_set_defaults(knobs);
  return ccolamd(n, n, static_cast<int>(length), rows, start, knobs, stats, sets) != 0;
}
inline bool Order(SuiteSparse_long n, size_t length, SuiteSparse_long* rows, SuiteSparse_long* start,
                  SuiteSparse_long* sets) {
  double knobs[CCOLAMD_KNOBS];
  SuiteSparse_long stats[CCOLAMD_STATS];
  ccolamd_l_set_defaults(knobs);
  return ccolamd_l(n, n, static_cast<SuiteSparse_long>(length), rows, start, knobs, stats, sets) != 0;
}

// KLU's user ordering: the columns of set 1 after those of set 0 (common->user_data holds the
// sets). Returns 0 on failure, else a positive estimate of nnz(L) (KLU sizes its first
// allocation with it).
template <typename Index, typename Common>
Index ConstrainedColamd(Index n, Index Ap[], Index Ai[], Index Perm[], Common* common) {
  auto& sets = *static_cast<std::vector<Index>*>(common->user_data);
  const Index nnz = Ap[n];
  const size_t length = Recommended(nnz, n);
  if (length == 0 || static_cast<Index>(sets.size()) != n) return 0;
  std::vector<Index> rows(length), start(Ap, Ap + n + 1);
  std::copy(Ai, Ai + nnz, rows.begin());
  if (!Order(n, length, rows.data(), start.data(), sets.data())) return 0;
  std::copy(start.begin(), start.begin() + n, Perm);
  return std::max<Index>(nnz, 1);
}

}  // namespace klu_ordering

// The ordering of `common` (before its analysis) keeps the columns `last` of its n × n matrices
// after all others; `sets` holds ccolamd's constraint sets and must outlive the analysis. No
// block triangular form first: the sets are the matrix's own columns (a saddle-point matrix of
// a connected model is one block anyway). Nothing changes when `last` is empty.
template <typename Common, typename Index>
void OrderColumnsLast(Common* common, int n, const std::vector<int>& last, std::vector<Index>* sets) {
  if (last.empty()) return;
  sets->assign(static_cast<size_t>(n), 0);
  for (const int j : last) (*sets)[static_cast<size_t>(j)] = 1;
  common->ordering = 3;  // the user's
  common->user_order = klu_ordering::ConstrainedColamd<Index, Common>;
  common->user_data = sets;
  common->btf = 0;
}

}  // namespace cosim::smooth
