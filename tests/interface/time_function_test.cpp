// Time functions: the cosine ramp of Eq. (37) of the CGα paper and tables, with derivatives
// checked against central differences.
#include "interface/scenario/time_function.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "interface/run/errors.h"

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

}  // namespace
}  // namespace cosim::interface
