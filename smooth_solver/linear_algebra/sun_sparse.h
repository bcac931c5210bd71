#pragma once
// A compressed-sparse-column Eigen matrix copied into a SUNDIALS sparse matrix of the same
// pattern (KLU solves it): the Jacobians of KINSOL and IDA are assembled in Eigen with a fixed
// pattern (fixed_pattern_matrix.h) and handed over by this copy.
#include <sunmatrix/sunmatrix_sparse.h>

#include <Eigen/SparseCore>

namespace cosim::smooth {

inline void CopyToSunSparse(const Eigen::SparseMatrix<double>& a, SUNMatrix J) {
  sunindextype* colptrs = SM_INDEXPTRS_S(J);
  sunindextype* rowvals = SM_INDEXVALS_S(J);
  realtype* data = SM_DATA_S(J);
  for (Eigen::Index c = 0; c <= a.outerSize(); ++c) colptrs[c] = a.outerIndexPtr()[c];
  for (Eigen::Index k = 0; k < a.nonZeros(); ++k) {
    rowvals[k] = a.innerIndexPtr()[k];
    data[k] = a.valuePtr()[k];
  }
}

}  // namespace cosim::smooth
