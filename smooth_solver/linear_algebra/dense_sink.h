#pragma once
// SparseSink into a SUNDIALS dense matrix (column-major), for KINSOL and IDA Jacobians.
#include <sunmatrix/sunmatrix_dense.h>

#include "smooth_solver/constraints/bilinear_constraints.h"

namespace cosim::smooth {

class SunDenseSink : public SparseSink {
 public:
  explicit SunDenseSink(SUNMatrix J, double scale = 1.0) : J_(J), scale_(scale) {}
  void Add(int row, int column, double value) override { SM_ELEMENT_D(J_, row, column) += scale_ * value; }

 private:
  SUNMatrix J_;
  double scale_;
};

}  // namespace cosim::smooth
