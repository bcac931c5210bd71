#include "interface/scenario/time_function.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace cosim::interface {

namespace {

// The second derivatives M_i of the natural cubic spline through (t_i, y_i) (M = 0 at both ends):
// continuity of the slope at every inner knot, (h_{i-1} M_{i-1} + 2 (h_{i-1} + h_i) M_i + h_i M_{i+1})/6
// = (y_{i+1} − y_i)/h_i − (y_i − y_{i-1})/h_{i-1}, solved by the Thomas algorithm (the system is
// diagonally dominant).
std::vector<double> NaturalSpline(const std::vector<double>& t, const std::vector<double>& y) {
  const size_t n = t.size();
  std::vector<double> m(n, 0.0);
  if (n < 3) return m;
  std::vector<double> diagonal(n, 1.0), upper(n, 0.0), rhs(n, 0.0);
  for (size_t i = 1; i + 1 < n; ++i) {
    const double a = t[i] - t[i - 1], b = t[i + 1] - t[i];
    const double lower = a / 6.0;
    diagonal[i] = (a + b) / 3.0;
    upper[i] = b / 6.0;
    rhs[i] = (y[i + 1] - y[i]) / b - (y[i] - y[i - 1]) / a;
    // Eliminate the sub-diagonal against row i − 1 (row 0 is M_0 = 0).
    const double factor = lower / diagonal[i - 1];
    diagonal[i] -= factor * upper[i - 1];
    rhs[i] -= factor * rhs[i - 1];
  }
  for (size_t i = n - 2; i >= 1; --i) m[i] = (rhs[i] - upper[i] * m[i + 1]) / diagonal[i];
  return m;
}

}  // namespace

TimeFunction TimeFunction::Constant(double value) {
  TimeFunction f;
  f.constant_ = value;
  return f;
}

TimeFunction TimeFunction::Build(const Checks& checks, const std::string& path, const scenario::TimeFunction& proto) {
  TimeFunction f;
  switch (proto.kind_case()) {
    case scenario::TimeFunction::kConstant:
      if (!std::isfinite(proto.constant())) checks.Fail(path + ".constant", "must be finite");
      f.constant_ = proto.constant();
      break;
    case scenario::TimeFunction::kCosineRamp: {
      const auto& r = proto.cosine_ramp();
      f.kind_ = Kind::kCosineRamp;
      checks.Require(path + ".cosine_ramp.final_value", r.has_final_value(), "the value reached after the ramp");
      f.final_value_ = r.final_value();
      f.ramp_time_ = checks.Positive(path + ".cosine_ramp.ramp_time", r.has_ramp_time(), r.ramp_time(), "s");
      f.start_time_ = r.start_time();
      break;
    }
    case scenario::TimeFunction::kCosinePulse: {
      const auto& r = proto.cosine_pulse();
      f.kind_ = Kind::kCosinePulse;
      checks.Require(path + ".cosine_pulse.peak", r.has_peak(), "the pulse's peak value");
      f.final_value_ = r.peak();
      f.ramp_time_ = checks.Positive(path + ".cosine_pulse.duration", r.has_duration(), r.duration(), "s");
      f.start_time_ = r.start_time();
      break;
    }
    case scenario::TimeFunction::kTable: {
      const auto& table = proto.table();
      f.kind_ = Kind::kTable;
      if (table.time_size() < 1) checks.Fail(path + ".table.time", "needs at least one time");
      if (table.time_size() != table.value_size()) {
        checks.Fail(path + ".table.value", "has " + std::to_string(table.value_size()) + " values for " +
                                               std::to_string(table.time_size()) + " times; they must match");
      }
      for (int i = 1; i < table.time_size(); ++i) {
        if (!(table.time(i) > table.time(i - 1))) {
          checks.Fail(path + ".table.time[" + std::to_string(i) + "]", "times must increase strictly, got " +
                                                                           FormatNumber(table.time(i)) + " after " +
                                                                           FormatNumber(table.time(i - 1)));
        }
      }
      f.time_.assign(table.time().begin(), table.time().end());
      f.value_.assign(table.value().begin(), table.value().end());
      if (table.interpolation() == scenario::TimeFunction::Table::CUBIC)
        f.curvature_ = NaturalSpline(f.time_, f.value_);
      break;
    }
    case scenario::TimeFunction::kSum: {
      f.kind_ = Kind::kSum;
      if (proto.sum().terms_size() == 0) checks.Fail(path + ".sum.terms", "is empty; give the functions to add");
      for (int i = 0; i < proto.sum().terms_size(); ++i) {
        f.terms_.push_back(Build(checks, path + ".sum.terms[" + std::to_string(i) + "]", proto.sum().terms(i)));
      }
      break;
    }
    case scenario::TimeFunction::kHarmonic: {
      const auto& h = proto.harmonic();
      f.kind_ = Kind::kHarmonic;
      checks.Require(path + ".harmonic.amplitude", h.has_amplitude(), "the amplitude");
      if (!std::isfinite(h.amplitude())) checks.Fail(path + ".harmonic.amplitude", "must be finite");
      f.final_value_ = h.amplitude();
      f.period_ = checks.Positive(path + ".harmonic.period", h.has_period(), h.period(), "s");
      f.phase_ = h.phase();
      f.start_time_ = h.start_time();
      f.ramp_time_ = checks.NonNegative(path + ".harmonic.ramp_time", h.ramp_time(), "s");
      break;
    }
    case scenario::TimeFunction::KIND_NOT_SET:
      checks.Fail(path,
                  "empty function; give constant, cosine_ramp { ... }, cosine_pulse { ... }, table { ... }, "
                  "harmonic { ... } or sum { ... }");
  }
  return f;
}

double TimeFunction::Value(double t) const {
  switch (kind_) {
    case Kind::kSum: {
      double sum = 0.0;
      for (const TimeFunction& term : terms_) sum += term.Value(t);
      return sum;
    }
    case Kind::kConstant:
      return constant_;
    case Kind::kHarmonic:
      return HarmonicDerivative(t, 0);
    case Kind::kCosineRamp: {
      // Eq. (37) of the CGα paper: ½ (1 − cos(π τ / T)) Ω for 0 <= τ < T.
      const double tau = t - start_time_;
      if (tau <= 0.0) return 0.0;
      if (tau >= ramp_time_) return final_value_;
      return 0.5 * (1.0 - std::cos(std::numbers::pi * tau / ramp_time_)) * final_value_;
    }
    case Kind::kCosinePulse: {
      // ½ (1 − cos(2π τ / T)) peak for 0 <= τ <= T, 0 outside.
      const double tau = t - start_time_;
      if (tau <= 0.0 || tau >= ramp_time_) return 0.0;
      return 0.5 * (1.0 - std::cos(2.0 * std::numbers::pi * tau / ramp_time_)) * final_value_;
    }
    case Kind::kTable:
      if (t <= time_.front()) return value_.front();
      if (t >= time_.back()) return value_.back();
      return TableDerivative(t, 0);
  }
  return 0.0;
}

double TimeFunction::Derivative(double t) const {
  switch (kind_) {
    case Kind::kSum: {
      double sum = 0.0;
      for (const TimeFunction& term : terms_) sum += term.Derivative(t);
      return sum;
    }
    case Kind::kConstant:
      return 0.0;
    case Kind::kHarmonic:
      return HarmonicDerivative(t, 1);
    case Kind::kCosineRamp: {
      const double tau = t - start_time_;
      if (tau <= 0.0 || tau >= ramp_time_) return 0.0;
      return 0.5 * std::numbers::pi / ramp_time_ * std::sin(std::numbers::pi * tau / ramp_time_) * final_value_;
    }
    case Kind::kCosinePulse: {
      const double tau = t - start_time_;
      if (tau <= 0.0 || tau >= ramp_time_) return 0.0;
      return std::numbers::pi / ramp_time_ * std::sin(2.0 * std::numbers::pi * tau / ramp_time_) * final_value_;
    }
    case Kind::kTable:
      if (t < time_.front() || t >= time_.back() || time_.size() < 2) return 0.0;
      return TableDerivative(t, 1);
  }
  return 0.0;
}

double TimeFunction::SecondDerivative(double t) const {
  if (kind_ == Kind::kSum) {
    double sum = 0.0;
    for (const TimeFunction& term : terms_) sum += term.SecondDerivative(t);
    return sum;
  }
  if (kind_ == Kind::kHarmonic) return HarmonicDerivative(t, 2);
  if (kind_ == Kind::kTable) {
    if (curvature_.empty() || t < time_.front() || t >= time_.back() || time_.size() < 2) return 0.0;
    return TableDerivative(t, 2);
  }
  if (kind_ != Kind::kCosineRamp && kind_ != Kind::kCosinePulse) return 0.0;
  const double tau = t - start_time_;
  if (tau <= 0.0 || tau >= ramp_time_) return 0.0;
  const double w = (kind_ == Kind::kCosinePulse ? 2.0 : 1.0) * std::numbers::pi / ramp_time_;
  return 0.5 * w * w * std::cos(w * tau) * final_value_;
}

double TimeFunction::Integral(double t) const {
  switch (kind_) {
    case Kind::kSum: {
      double sum = 0.0;
      for (const TimeFunction& term : terms_) sum += term.Integral(t);
      return sum;
    }
    case Kind::kConstant:
      return constant_ * t;
    case Kind::kHarmonic: {
      // F(t) − F(0), F the integral from start_time: ∫ r A sin(ω τ + φ) dτ with r = ½ (1 − cos(a τ))
      // over the ramp (a = π / T_r), the product split into sines of (ω ± a) τ + φ, each
      // integrated exactly, and r = 1 after it (or throughout, without a ramp).
      const double w = 2.0 * std::numbers::pi / period_;
      auto sine = [&](double k, double from, double to) {  // ∫ sin(k τ + φ) dτ
        if (k == 0.0) return (to - from) * std::sin(phase_);
        return (std::cos(k * from + phase_) - std::cos(k * to + phase_)) / k;
      };
      auto from_start = [&](double at) {
        const double tau = at - start_time_;
        if (ramp_time_ <= 0.0) return final_value_ * sine(w, 0.0, tau);
        if (tau <= 0.0) return 0.0;
        const double a = std::numbers::pi / ramp_time_, ramp = std::min(tau, ramp_time_);
        double value =
            0.5 * final_value_ * (sine(w, 0.0, ramp) - 0.5 * (sine(w + a, 0.0, ramp) + sine(w - a, 0.0, ramp)));
        if (tau > ramp_time_) value += final_value_ * sine(w, ramp_time_, tau);
        return value;
      };
      return from_start(t) - from_start(0.0);
    }
    case Kind::kCosineRamp: {
      // ∫ ½(1 − cos(π τ/T)) F dτ = ½ F (τ − (T/π) sin(π τ/T)) over the ramp, then F per second.
      const double tau = std::min(std::max(t - start_time_, 0.0), ramp_time_);
      double value =
          0.5 * final_value_ * (tau - ramp_time_ / std::numbers::pi * std::sin(std::numbers::pi * tau / ramp_time_));
      if (t - start_time_ > ramp_time_) value += final_value_ * (t - start_time_ - ramp_time_);
      return value;
    }
    case Kind::kCosinePulse: {
      const double tau = std::min(std::max(t - start_time_, 0.0), ramp_time_), w = 2.0 * std::numbers::pi / ramp_time_;
      return 0.5 * final_value_ * (tau - std::sin(w * tau) / w);
    }
    case Kind::kTable: {
      // F(t) − F(0) with F(τ) = ∫ from time_[0]: each segment's exact integral, the end values
      // held outside the table.
      auto from_first = [&](double at) {
        if (at <= time_.front()) return value_.front() * (at - time_.front());
        double value = 0.0;
        size_t i = 0;
        for (; i + 1 < time_.size() && time_[i + 1] <= at; ++i) value += SegmentIntegral(i, time_[i + 1]);
        if (i + 1 < time_.size()) return value + SegmentIntegral(i, at);
        return value + value_.back() * (at - time_.back());
      };
      return from_first(t) - from_first(0.0);
    }
  }
  return 0.0;
}

double TimeFunction::TableDerivative(double t, int order) const {
  // Within [t_i, t_{i+1}] (h long), b = (t − t_i)/h, a = 1 − b:
  //   S = a y_i + b y_{i+1} + ((a³ − a) M_i + (b³ − b) M_{i+1}) h²/6     (M = 0: the linear table),
  //   S' = (y_{i+1} − y_i)/h + ((1 − 3a²) M_i + (3b² − 1) M_{i+1}) h/6,   S'' = a M_i + b M_{i+1}.
  const size_t i = static_cast<size_t>(std::upper_bound(time_.begin(), time_.end(), t) - time_.begin()) - 1;
  const double h = time_[i + 1] - time_[i], b = (t - time_[i]) / h, a = 1.0 - b;
  const double mi = curvature_.empty() ? 0.0 : curvature_[i], mj = curvature_.empty() ? 0.0 : curvature_[i + 1];
  if (order == 0)
    return a * value_[i] + b * value_[i + 1] + ((a * a * a - a) * mi + (b * b * b - b) * mj) * h * h / 6.0;
  if (order == 1)
    return (value_[i + 1] - value_[i]) / h + ((1.0 - 3.0 * a * a) * mi + (3.0 * b * b - 1.0) * mj) * h / 6.0;
  return a * mi + b * mj;
}

double TimeFunction::SegmentIntegral(size_t i, double t) const {
  // ∫ S dt from t_i to t = h ∫_0^B S db: h [y_i (B − B²/2) + y_{i+1} B²/2] plus, for the spline,
  // h³/6 [M_i (¼ − ½ − (1 − B)⁴/4 + (1 − B)²/2) + M_{i+1} (B⁴/4 − B²/2)].
  const double h = time_[i + 1] - time_[i], b = (t - time_[i]) / h, a = 1.0 - b;
  double value = h * (value_[i] * (b - 0.5 * b * b) + value_[i + 1] * 0.5 * b * b);
  if (!curvature_.empty()) {
    value += h * h * h / 6.0 *
             (curvature_[i] * (-0.25 - 0.25 * a * a * a * a + 0.5 * a * a) +
              curvature_[i + 1] * (0.25 * b * b * b * b - 0.5 * b * b));
  }
  return value;
}

double TimeFunction::HarmonicDerivative(double t, int order) const {
  // f = r g with g = A sin(ω τ + φ): f' = r' g + r g', f'' = r'' g + 2 r' g' + r g''.
  const double tau = t - start_time_;
  if (tau < 0.0 && ramp_time_ > 0.0) return 0.0;
  const double w = 2.0 * std::numbers::pi / period_, angle = w * tau + phase_;
  const double g[3] = {final_value_ * std::sin(angle), final_value_ * w * std::cos(angle),
                       -final_value_ * w * w * std::sin(angle)};
  double r[3] = {1.0, 0.0, 0.0};
  if (ramp_time_ > 0.0 && tau < ramp_time_) {
    const double a = std::numbers::pi / ramp_time_;
    r[0] = 0.5 * (1.0 - std::cos(a * tau));
    r[1] = 0.5 * a * std::sin(a * tau);
    r[2] = 0.5 * a * a * std::cos(a * tau);
  }
  if (order == 0) return r[0] * g[0];
  if (order == 1) return r[1] * g[0] + r[0] * g[1];
  return r[2] * g[0] + 2.0 * r[1] * g[1] + r[0] * g[2];
}

}  // namespace cosim::interface
