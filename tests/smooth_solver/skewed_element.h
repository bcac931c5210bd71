#pragma once
// Test fixture shared by the element tests: a skewed reference 27-node element (the
// unit-spaced node grid, sheared and scaled), so that nothing holds by axis alignment.
#include <Eigen/Core>

#include "smooth_solver/elastic/hex27.h"

namespace cosim::smooth::fixtures {

inline Hex27::NodeMatrix SkewedReference() {
  Hex27::NodeMatrix X;
  Eigen::Matrix3d A;
  A << 0.5, 0.05, 0.0, 0.02, 0.3, 0.01, 0.0, 0.03, 0.2;
  for (int k = 0; k < 3; ++k) {
    for (int j = 0; j < 3; ++j) {
      for (int i = 0; i < 3; ++i) X.col(i + 3 * j + 9 * k) = A * Eigen::Vector3d(i - 1.0, j - 1.0, k - 1.0);
    }
  }
  return X;
}

}  // namespace cosim::smooth::fixtures
