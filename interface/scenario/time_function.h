#pragma once
// f(t) and df/dt of a scenario TimeFunction (constant, cosine ramp of Eq. (37) of the CGα
// paper, a 1 − cos pulse, a piecewise-linear or natural cubic spline table, a ramped harmonic,
// or a sum of them), validated when built.
#include <vector>

#include "interface/scenario/checks.h"
#include "scenario.pb.h"

namespace cosim::interface {

class TimeFunction {
 public:
  TimeFunction() = default;  // f = 0
  static TimeFunction Constant(double value);
  // Throws InputError at `path` for an empty function, a non-positive ramp time, or a table
  // whose times do not increase or whose columns differ in length.
  static TimeFunction Build(const Checks& checks, const std::string& path, const scenario::TimeFunction& proto);

  double Value(double t) const;
  double Derivative(double t) const;
  double SecondDerivative(double t) const;  // 0 for linear tables
  double Integral(double t) const;          // ∫_0^t f dτ
  bool IsZero() const { return kind_ == Kind::kConstant && constant_ == 0.0; }

 private:
  enum class Kind { kConstant, kCosineRamp, kCosinePulse, kTable, kSum, kHarmonic };
  // A harmonic's value (derivative 0), its first or its second derivative at t; its ramp's.
  double HarmonicDerivative(double t, int order) const;
  // A table's value (order 0), first or second derivative at t inside its range; its integral
  // from time_[i] to t within segment i.
  double TableDerivative(double t, int order) const;
  double SegmentIntegral(size_t i, double t) const;
  Kind kind_ = Kind::kConstant;
  double constant_ = 0.0;
  double final_value_ = 0.0, ramp_time_ = 1.0, start_time_ = 0.0;
  std::vector<double> time_, value_;
  std::vector<double> curvature_;      // kTable, cubic: the spline's second derivative at each time
  std::vector<TimeFunction> terms_;    // kSum
  double period_ = 1.0, phase_ = 0.0;  // kHarmonic (amplitude in final_value_, ramp in ramp_time_)
};

}  // namespace cosim::interface
