#include "interface/coupling/relaxation.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace cosim::interface {

Relaxation::Relaxation(Method method, int size, double factor, int max_columns, int reuse_steps)
    : method_(method),
      factor_(factor),
      omega_(factor),
      max_columns_(max_columns > 0 ? max_columns : std::max(size, 1)),
      reuse_steps_(std::max(reuse_steps, 0)) {
  stamp_.assign(static_cast<size_t>(max_columns_), 0);
  r_.setZero(size);
  r_previous_.setZero(size);
  x_tilde_previous_.setZero(size);
  dr_.setZero(size);
  V_.resize(size, max_columns_);
  W_.resize(size, max_columns_);
  alpha_.resize(max_columns_);
}

void Relaxation::BeginStep() {
  iteration_ = 0;
  omega_ = factor_;
  ++step_;
  // Columns are newest first: keep those made in the last `reuse_steps_` steps.
  while (columns_ > 0 && stamp_[static_cast<size_t>(columns_ - 1)] < step_ - reuse_steps_) --columns_;
}

void Relaxation::Write(state::RelaxationMemory* out) const {
  out->set_method(static_cast<int>(method_));
  out->set_reuse_steps(reuse_steps_);
  out->set_size(static_cast<int>(V_.rows()));
  out->set_step(step_);
  out->mutable_stamp()->Add(stamp_.begin(), stamp_.begin() + columns_);
  const Eigen::Index values = V_.rows() * columns_;
  out->mutable_v()->Add(V_.data(), V_.data() + values);  // column-major: the columns in use first
  out->mutable_w()->Add(W_.data(), W_.data() + values);
}

std::string Relaxation::Read(const state::RelaxationMemory& in, bool* restored) {
  *restored = false;
  if (in.method() != static_cast<int>(method_) || in.reuse_steps() != reuse_steps_) return {};
  const int columns = in.stamp_size();
  const int size = static_cast<int>(V_.rows());
  if (in.size() != size || columns > max_columns_ || in.v_size() != size * columns || in.w_size() != size * columns) {
    return "relaxation memory holds " + std::to_string(columns) + " columns of " + std::to_string(in.size()) +
           " values (" + std::to_string(in.v_size()) + " and " + std::to_string(in.w_size()) +
           " numbers); this coupling keeps at most " + std::to_string(max_columns_) + " of " + std::to_string(size);
  }
  for (int i = 0; i < in.v_size(); ++i) {
    if (!std::isfinite(in.v(i)) || !std::isfinite(in.w(i))) {
      return "relaxation memory's column values at " + std::to_string(i) + " are not finite";
    }
  }
  step_ = in.step();
  columns_ = columns;
  std::copy(in.stamp().begin(), in.stamp().end(), stamp_.begin());
  std::copy(in.v().begin(), in.v().end(), V_.data());
  std::copy(in.w().begin(), in.w().end(), W_.data());
  *restored = true;
  return {};
}

void Relaxation::Forget() {
  iteration_ = 0;
  columns_ = 0;
  omega_ = factor_;
}

void Relaxation::Next(const Eigen::VectorXd& x, const Eigen::VectorXd& x_tilde, Eigen::VectorXd* x_next) {
  r_ = x_tilde - x;
  const double r_norm = r_.norm();
  if (r_norm == 0.0) {  // already a fixed point: no secant information, the next call starts afresh
    *x_next = x_tilde;
    return;
  }
  switch (method_) {
    case Method::kConstant:
      omega_ = factor_;
      *x_next = x + omega_ * r_;
      break;
    case Method::kAitken: {
      if (iteration_ == 0) {
        omega_ = factor_;
      } else {
        dr_ = r_ - r_previous_;
        const double dr2 = dr_.squaredNorm();
        // A stalled iteration (no change of residual) keeps the last ω.
        if (dr2 > 0.0) omega_ = std::clamp(-omega_ * r_previous_.dot(dr_) / dr2, -2.0, 2.0);
      }
      *x_next = x + omega_ * r_;
      break;
    }
    case Method::kIqnIls: {
      if (iteration_ > 0) {
        // New column (newest first): Δr = r_i − r_{i−1}, Δx̃ = x̃_i − x̃_{i−1}.
        const int keep = std::min(columns_, max_columns_ - 1);
        for (int c = keep; c > 0; --c) {
          V_.col(c) = V_.col(c - 1);
          W_.col(c) = W_.col(c - 1);
          stamp_[static_cast<size_t>(c)] = stamp_[static_cast<size_t>(c - 1)];
        }
        V_.col(0) = r_ - r_previous_;
        W_.col(0) = x_tilde - x_tilde_previous_;
        stamp_[0] = step_;
        columns_ = keep + 1;
      }
      // Drop the oldest columns until the fit is well conditioned.
      bool updated = false;
      while (columns_ > 0) {
        Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(V_.leftCols(columns_));
        qr.setThreshold(1e-10);
        if (qr.rank() == columns_) {
          alpha_.head(columns_) = qr.solve(-r_);
          *x_next = x_tilde + W_.leftCols(columns_) * alpha_.head(columns_);
          updated = true;
          break;
        }
        --columns_;
      }
      if (!updated) *x_next = x + factor_ * r_;  // first iteration without reused columns
      break;
    }
  }
  r_previous_ = r_;
  x_tilde_previous_ = x_tilde;
  ++iteration_;
}

}  // namespace cosim::interface
