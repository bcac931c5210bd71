#pragma once
// A sparse matrix whose sparsity pattern is fixed once (every entry any assembly may touch),
// then re-filled in place for each Newton iteration: no insertion, no reallocation, and the
// sparse LU's symbolic analysis (KLU's klu_analyze, KluSolver::Analyze) is done once and reused.
#include <Eigen/SparseCore>
#include <algorithm>
#include <array>
#include <string>
#include <vector>

#include "interface/base/errors.h"
#include "smooth_solver/constraints/bilinear_constraints.h"

namespace cosim::smooth {

// Collects the pattern: Add records (row, column) whatever the value.
class PatternSink : public SparseSink {
 public:
  void Add(int row, int column, double) override { entries_.emplace_back(row, column, 0.0); }
  Eigen::SparseMatrix<double> Build(int rows, int columns) const {
    Eigen::SparseMatrix<double> m(rows, columns);
    m.setFromTriplets(entries_.begin(), entries_.end());
    m.makeCompressed();
    return m;
  }

 private:
  std::vector<Eigen::Triplet<double>> entries_;
};

// Adds into existing entries of a compressed column-major matrix, found by binary search.
// An entry outside the fixed pattern is a bug in the pattern (it would silently change the
// structure the factorisation was analysed for): always-on assertion.
class MatrixSink : public SparseSink {
 public:
  explicit MatrixSink(Eigen::SparseMatrix<double>* m) : m_(m) {}
  void Add(int row, int column, double value) override {
    const int* inner = m_->innerIndexPtr();
    const int* begin = inner + m_->outerIndexPtr()[column];
    const int* end = inner + m_->outerIndexPtr()[column + 1];
    const int* it = std::lower_bound(begin, end, row);
    COSIM_ASSERT(it != end && *it == row, "sparse entry (" + std::to_string(row) + ", " + std::to_string(column) +
                                              ") outside the fixed pattern");
    m_->valuePtr()[it - inner] += value;
  }
  // One search per column: a block's three rows are consecutive in a pattern that holds it.
  void AddBlock3(int row, int column, const Eigen::Matrix3d& block) override {
    const int* inner = m_->innerIndexPtr();
    for (int c = 0; c < 3; ++c) {
      const int* begin = inner + m_->outerIndexPtr()[column + c];
      const int* end = inner + m_->outerIndexPtr()[column + c + 1];
      const int* it = std::lower_bound(begin, end, row);
      COSIM_ASSERT(
          end - it >= 3 && it[0] == row && it[2] == row + 2,
          "3x3 block at (" + std::to_string(row) + ", " + std::to_string(column + c) + ") outside the fixed pattern");
      double* v = m_->valuePtr() + (it - inner);
      v[0] += block(0, c);
      v[1] += block(1, c);
      v[2] += block(2, c);
    }
  }
  // One merge of the sorted rows with each column's pattern (no search per entry: the scatter of
  // an element matrix was ~14 % of a hex27 CGα step with Add).
  void AddDense(const int* index, int count, const double* values, double scale) override {
    if (count > kMaxDense) {
      SparseSink::AddDense(index, count, values, scale);
      return;
    }
    std::array<int, kMaxDense> order;  // on the stack: steps do not allocate
    for (int k = 0; k < count; ++k) order[static_cast<size_t>(k)] = k;
    std::sort(order.begin(), order.begin() + count, [&](int a, int b) { return index[a] < index[b]; });
    const int* inner = m_->innerIndexPtr();
    double* value = m_->valuePtr();
    for (int c = 0; c < count; ++c) {
      int p = m_->outerIndexPtr()[index[c]];
      const int end = m_->outerIndexPtr()[index[c] + 1];
      const double* column = values + static_cast<ptrdiff_t>(c) * count;
      for (int o = 0; o < count; ++o) {
        const int k = order[static_cast<size_t>(o)];
        const int row = index[k];
        while (p < end && inner[p] < row) ++p;
        COSIM_ASSERT(p < end && inner[p] == row, "sparse entry (" + std::to_string(row) + ", " +
                                                     std::to_string(index[c]) + ") outside the fixed pattern");
        value[p] += scale * column[k];
      }
    }
  }

 private:
  Eigen::SparseMatrix<double>* m_;
};

// Adds into another sink at a row and column offset, scaled (blocks of a larger matrix).
class OffsetSink : public SparseSink {
 public:
  OffsetSink(SparseSink* inner, int row, int column, double scale = 1.0)
      : inner_(inner), row_(row), column_(column), scale_(scale) {}
  void Add(int r, int c, double value) override { inner_->Add(r + row_, c + column_, scale_ * value); }
  void AddBlock3(int r, int c, const Eigen::Matrix3d& block) override {
    inner_->AddBlock3(r + row_, c + column_, scale_ * block);
  }
  void AddDense(const int* index, int count, const double* values, double scale) override {
    if (row_ != column_ || count > kMaxDense) {
      SparseSink::AddDense(index, count, values, scale);
      return;
    }
    std::array<int, kMaxDense> shifted;  // on the stack: steps do not allocate
    for (int k = 0; k < count; ++k) shifted[static_cast<size_t>(k)] = index[k] + row_;
    inner_->AddDense(shifted.data(), count, values, scale_ * scale);
  }

 private:
  SparseSink* inner_;
  int row_, column_;
  double scale_;
};

// sink += scale · a.
inline void AddSparse(const Eigen::SparseMatrix<double>& a, double scale, SparseSink* sink) {
  for (int k = 0; k < a.outerSize(); ++k) {
    for (Eigen::SparseMatrix<double>::InnerIterator it(a, k); it; ++it) {
      sink->Add(static_cast<int>(it.row()), static_cast<int>(it.col()), scale * it.value());
    }
  }
}

}  // namespace cosim::smooth
