// Time functions: the cosine ramp of Eq. (37) of the CGα paper and tables, with derivatives
// checked against central differences.
#include "interface/scenario/time_function.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "interface/base/errors.h"

namespace cosim::interface {
namespace {

TEST(TimeFunction, CosineRampMatchesEquation37AndItsDerivative) {
  const ScenarioFile f = ScenarioFile::Parse("", "f", {});
  const Checks checks(f);
  scenario::TimeFunction proto;
  proto.mutable_cosine_ramp()->set_final_value(40.0);
  proto.mutable_cosine_ramp()->set_ramp_time(2.0);
  const TimeFunction ramp = TimeFunction::Build(checks, "x", proto);
  // ω(τ/2) = ½(1 − cos(π/2)) Ω = Ω/2 exactly; ω = Ω after the ramp.
  EXPECT_NEAR(ramp.Value(1.0), 20.0, 1e-12);
  EXPECT_DOUBLE_EQ(ramp.Value(3.0), 40.0);
  EXPECT_DOUBLE_EQ(ramp.Value(-1.0), 0.0);
  for (double t : {0.3, 1.0, 1.7}) {
    const double fd = (ramp.Value(t + 1e-6) - ramp.Value(t - 1e-6)) / 2e-6;
    EXPECT_NEAR(ramp.Derivative(t), fd, 1e-6 * 40.0);
    const double fd2 = (ramp.Derivative(t + 1e-6) - ramp.Derivative(t - 1e-6)) / 2e-6;
    EXPECT_NEAR(ramp.SecondDerivative(t), fd2, 1e-5 * 40.0);
    const double fi = (ramp.Integral(t + 1e-6) - ramp.Integral(t - 1e-6)) / 2e-6;
    EXPECT_NEAR(fi, ramp.Value(t), 1e-6 * 40.0);
  }
  // After the ramp: ½ F T of ramp, then F per second.
  EXPECT_NEAR(ramp.Integral(3.0), 0.5 * 40.0 * 2.0 + 40.0, 1e-12);
}

TEST(TimeFunction, CosinePulseRisesToItsPeakAndBackWithItsDerivativesAndIntegral) {
  // ½ (1 − cos(2π τ/T)) peak: the gust profile of docs/reference/aero.md.
  const ScenarioFile f = ScenarioFile::Parse("", "f", {});
  const Checks checks(f);
  scenario::TimeFunction proto;
  proto.mutable_cosine_pulse()->set_peak(25.0);
  proto.mutable_cosine_pulse()->set_duration(4.0);
  proto.mutable_cosine_pulse()->set_start_time(1.0);
  const TimeFunction pulse = TimeFunction::Build(checks, "x", proto);
  EXPECT_DOUBLE_EQ(pulse.Value(0.5), 0.0);
  EXPECT_NEAR(pulse.Value(3.0), 25.0, 1e-12);
  EXPECT_NEAR(pulse.Value(2.0), 12.5, 1e-12);
  EXPECT_DOUBLE_EQ(pulse.Value(5.5), 0.0);
  for (double t : {1.3, 2.0, 3.7, 4.9}) {
    EXPECT_NEAR(pulse.Derivative(t), (pulse.Value(t + 1e-6) - pulse.Value(t - 1e-6)) / 2e-6, 1e-6 * 25.0);
    EXPECT_NEAR(pulse.SecondDerivative(t), (pulse.Derivative(t + 1e-6) - pulse.Derivative(t - 1e-6)) / 2e-6,
                1e-5 * 25.0);
  }
  EXPECT_NEAR(pulse.Integral(10.0), 0.5 * 25.0 * 4.0, 1e-12);  // the mean ½ peak over its duration
  scenario::TimeFunction bad;
  bad.mutable_cosine_pulse()->set_peak(1.0);
  bad.mutable_cosine_pulse()->set_duration(0.0);
  EXPECT_THROW(TimeFunction::Build(checks, "x", bad), InputError);
}

TEST(TimeFunction, HarmonicStartsSmoothlyThroughItsRampWithExactDerivativesAndIntegral) {
  // A deck's roll: 5° (0.0873 rad) with a 10 s period and a 0.4 rad phase from t = 1 s, its
  // amplitude ramped in over 6 s: zero before the start, value and slope zero at it (r = r' = 0
  // there), half the sine at half the ramp, the plain sine after it.
  const ScenarioFile f = ScenarioFile::Parse("", "f", {});
  const Checks checks(f);
  const double a = 0.0873, period = 10.0, phase = 0.4, start = 1.0, ramp_time = 6.0;
  scenario::TimeFunction proto;
  auto* h = proto.mutable_harmonic();
  h->set_amplitude(a);
  h->set_period(period);
  h->set_phase(phase);
  h->set_start_time(start);
  h->set_ramp_time(ramp_time);
  const TimeFunction roll = TimeFunction::Build(checks, "x", proto);
  const double w = 2.0 * std::numbers::pi / period;
  EXPECT_DOUBLE_EQ(roll.Value(0.5), 0.0);
  EXPECT_DOUBLE_EQ(roll.Value(start), 0.0);
  EXPECT_DOUBLE_EQ(roll.Derivative(start), 0.0);
  EXPECT_NEAR(roll.Value(9.0), a * std::sin(w * 8.0 + phase), 1e-15);
  EXPECT_NEAR(roll.Value(start + 3.0), 0.5 * a * std::sin(w * 3.0 + phase), 1e-15);  // r(T/2) = ½
  for (double t : {1.2, 3.0, 6.9, 7.1, 12.3}) {
    EXPECT_NEAR(roll.Derivative(t), (roll.Value(t + 1e-6) - roll.Value(t - 1e-6)) / 2e-6, 1e-8) << t;
    EXPECT_NEAR(roll.SecondDerivative(t), (roll.Derivative(t + 1e-6) - roll.Derivative(t - 1e-6)) / 2e-6, 1e-8) << t;
    EXPECT_NEAR((roll.Integral(t + 1e-6) - roll.Integral(t - 1e-6)) / 2e-6, roll.Value(t), 1e-9) << t;
  }
  // The integral against a fine midpoint sum from 0 to 12.3 s (through the ramp's end).
  double sum = 0.0;
  const int n = 200000;
  for (int i = 0; i < n; ++i) sum += roll.Value((i + 0.5) * 12.3 / n) * 12.3 / n;
  EXPECT_NEAR(roll.Integral(12.3), sum, 1e-9);
  // Without a ramp: A sin(ω (t − start) + φ) at every time, before the start too (so that a
  // constant plus a harmonic, A (1 − cos ωt), is smooth where CGα's first step reads it, just
  // before t = 0); its integral from 0, (cos(−ω start + φ) − cos(ω (t − start) + φ)) A / ω.
  h->clear_ramp_time();
  const TimeFunction plain = TimeFunction::Build(checks, "x", proto);
  EXPECT_NEAR(plain.Value(start), a * std::sin(phase), 1e-15);
  EXPECT_NEAR(plain.Value(0.0), a * std::sin(-w * start + phase), 1e-15);
  EXPECT_NEAR(plain.Integral(4.0), a * (std::cos(-w * start + phase) - std::cos(w * 3.0 + phase)) / w, 1e-15);
  // A period that is not positive, or no amplitude, is refused naming the field.
  h->set_period(0.0);
  try {
    TimeFunction::Build(checks, "model.moving_bases[0].roll", proto);
    FAIL() << "accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("model.moving_bases[0].roll.harmonic.period"), std::string::npos) << e.what();
  }
  h->set_period(10.0);
  h->clear_amplitude();
  EXPECT_THROW(TimeFunction::Build(checks, "x", proto), InputError);
}

TEST(TimeFunction, SumOfARampUpAndARampDownIsAnEngagementAndRunDown) {
  // docs/reference/puma.md: Ω(t) = ½(1 − cos(πt/20)) Ω100% up to 20 s, held, the mirror run-down from
  // 30 s to rest at 50 s — a cosine ramp plus a negative one starting at 30 s.
  const ScenarioFile f = ScenarioFile::Parse("", "f", {});
  const Checks checks(f);
  scenario::TimeFunction proto;
  auto* up = proto.mutable_sum()->add_terms()->mutable_cosine_ramp();
  up->set_final_value(28.0);
  up->set_ramp_time(20.0);
  auto* down = proto.mutable_sum()->add_terms()->mutable_cosine_ramp();
  down->set_final_value(-28.0);
  down->set_ramp_time(20.0);
  down->set_start_time(30.0);
  const TimeFunction omega = TimeFunction::Build(checks, "x", proto);
  EXPECT_NEAR(omega.Value(10.0), 14.0, 1e-12);
  EXPECT_NEAR(omega.Value(25.0), 28.0, 1e-12);
  EXPECT_NEAR(omega.Value(40.0), 14.0, 1e-12);
  EXPECT_NEAR(omega.Value(60.0), 0.0, 1e-12);
  EXPECT_NEAR(omega.Derivative(35.0), -28.0 * std::numbers::pi / 40 * std::sin(std::numbers::pi / 4), 1e-12);
  EXPECT_NEAR(omega.Integral(50.0), 28.0 * 30.0, 1e-9);  // 10 s up + 10 s held + 10 s down: 30 s at Ω
  scenario::TimeFunction empty;
  empty.mutable_sum();
  EXPECT_THROW(TimeFunction::Build(checks, "x", empty), InputError);
}

TEST(TimeFunction, TableInterpolatesLinearlyAndRejectsDecreasingTimes) {
  const ScenarioFile f = ScenarioFile::Parse("", "f", {});
  const Checks checks(f);
  scenario::TimeFunction proto;
  for (double t : {0.0, 1.0, 3.0}) proto.mutable_table()->add_time(t);
  for (double v : {0.0, 2.0, -2.0}) proto.mutable_table()->add_value(v);
  const TimeFunction table = TimeFunction::Build(checks, "x", proto);
  EXPECT_DOUBLE_EQ(table.Value(0.5), 1.0);
  EXPECT_DOUBLE_EQ(table.Value(2.0), 0.0);
  EXPECT_DOUBLE_EQ(table.Derivative(2.0), -2.0);
  EXPECT_DOUBLE_EQ(table.Value(9.0), -2.0);
  // ∫0^2: triangle to (1, 2) gives 1, then from (1, 2) to (2, 0) gives 1.
  EXPECT_DOUBLE_EQ(table.Integral(2.0), 2.0);
  proto.mutable_table()->set_time(2, 0.5);
  EXPECT_THROW(TimeFunction::Build(checks, "x", proto), InputError);
}

TEST(TimeFunction, CubicTableIsTheNaturalSplineTwiceContinuousWithExactDerivativesAndIntegral) {
  // A ship's roll record sampled every 0.25 s (sin over 0 … 6 s, unequal steps near the end):
  // the natural cubic spline through it is C² at every knot (CGα reads a drive's acceleration),
  // has S'' = 0 at both ends, follows the sine to O(h⁴) inside (measured against it, away from
  // the ends where the natural condition S'' = 0 differs from the sine's), and its derivatives
  // and integral are the spline's own (central differences, a midpoint sum).
  const ScenarioFile f = ScenarioFile::Parse("", "f", {});
  const Checks checks(f);
  scenario::TimeFunction proto;
  auto* table = proto.mutable_table();
  table->set_interpolation(scenario::TimeFunction::Table::CUBIC);
  std::vector<double> knots;
  for (int i = 0; i <= 22; ++i) knots.push_back(0.25 * i);
  knots.push_back(5.9);
  knots.push_back(6.0);
  for (double t : knots) {
    table->add_time(t);
    table->add_value(std::sin(t));
  }
  const TimeFunction spline = TimeFunction::Build(checks, "x", proto);
  for (double t : knots) EXPECT_NEAR(spline.Value(t), std::sin(t), 1e-14) << t;
  for (size_t i = 1; i + 1 < knots.size(); ++i) {
    const double t = knots[i], e = 1e-9;
    EXPECT_NEAR(spline.Derivative(t - e), spline.Derivative(t + e), 1e-8) << t;
    EXPECT_NEAR(spline.SecondDerivative(t - e), spline.SecondDerivative(t + e), 1e-8) << t;
  }
  EXPECT_NEAR(spline.SecondDerivative(0.0), 0.0, 1e-14);
  EXPECT_NEAR(spline.SecondDerivative(6.0 - 1e-12), 0.0, 1e-10);
  double worst = 0.0;
  for (double t = 1.0; t < 5.0; t += 0.01) worst = std::max(worst, std::abs(spline.Value(t) - std::sin(t)));
  EXPECT_LT(worst, 2e-4);  // natural end conditions reach in; the interior's own O(h⁴) error is ~5e-5
  for (double t : {0.1, 1.37, 3.0, 5.95}) {
    EXPECT_NEAR(spline.Derivative(t), (spline.Value(t + 1e-6) - spline.Value(t - 1e-6)) / 2e-6, 1e-8) << t;
    EXPECT_NEAR(spline.SecondDerivative(t), (spline.Derivative(t + 1e-6) - spline.Derivative(t - 1e-6)) / 2e-6, 1e-7)
        << t;
  }
  double sum = 0.0;
  const int n = 200000;
  for (int i = 0; i < n; ++i) sum += spline.Value((i + 0.5) * 7.0 / n) * 7.0 / n;  // past the end: held
  EXPECT_NEAR(spline.Integral(7.0), sum, 1e-9);
  EXPECT_NEAR(spline.Integral(7.0) - spline.Integral(6.0), std::sin(6.0), 1e-12);
  // Two points: the spline is the straight line.
  scenario::TimeFunction two;
  two.mutable_table()->set_interpolation(scenario::TimeFunction::Table::CUBIC);
  for (double t : {1.0, 3.0}) two.mutable_table()->add_time(t);
  for (double v : {2.0, -2.0}) two.mutable_table()->add_value(v);
  const TimeFunction line = TimeFunction::Build(checks, "x", two);
  EXPECT_DOUBLE_EQ(line.Value(2.5), -1.0);
  EXPECT_DOUBLE_EQ(line.Derivative(2.0), -2.0);
}

}  // namespace
}  // namespace cosim::interface
