// numerics.adaptive: CGα with its own step size in a standalone run, the history on
// the output grid by interpolation. Why each test holds is stated in it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "interface/base/errors.h"
#include "smooth_solver/integrator/stepper.h"
#include "smooth_solver/simulation/multibody_simulation.h"

namespace cosim::smooth {
namespace {

// A 1 kg mass on a 100 N/m spring along a prismatic slide, released 0.1 m from rest:
// z(t) = 0.1 cos(10 t) about its rest point.
const char* kOscillator = R"(
  name: "oscillator"
  model {
    bodies { name: "mass" mass: 1 inertia: [0.01, 0.01, 0.01] position: [0, 0, 0.1] }
    joints { name: "slide" type: PRISMATIC body1: "ground" body2: "mass" point: [0, 0, 0] axis: [0, 0, 1] }
    forces { name: "spring" joint_spring { joint: "slide" stiffness: 100 rest_value: -0.1 } }
  }
  numerics { end_time: 2 step: 0.01 smooth { newton_tolerance: 1e-12 } }
  output { probes { name: "z" quantity: POSITION entity: "mass" component: Z } }
)";

struct Outputs {
  std::vector<double> time, value;  // on the output grid
  double accepted = 0.0, rejected = 0.0;
};

Outputs Drive(MultibodySimulation* sim, double start, double end, double h, int probe) {
  Outputs r;
  const long n = std::lround((end - start) / h);
  std::vector<double> v(sim->ProbeNames().size());
  for (long k = 0; k < n; ++k) {
    const double t = start + static_cast<double>(k) * h, t1 = start + static_cast<double>(k + 1) * h;
    sim->Step(t, t1 - t);
    sim->Probe(&v);
    r.time.push_back(t1);
    r.value.push_back(v[static_cast<size_t>(probe)]);
  }
  run::RunSummary summary;
  sim->FillSummary(&summary);
  r.accepted = summary.counters().count("adaptive_accepted_steps") ? summary.counters().at("adaptive_accepted_steps")
                                                                   : static_cast<double>(n);
  r.rejected =
      summary.counters().count("adaptive_rejected_steps") ? summary.counters().at("adaptive_rejected_steps") : 0;
  return r;
}

TEST(AdaptiveStep, AnOscillatorsErrorFollowsTheToleranceOnTheOutputGrid) {
  // The controller keeps the local error estimate |β − 1/6| h² Δa at the tolerance, so h ∝ tol^(1/3)
  // and the global error of the second-order scheme ∝ h² ∝ tol^(2/3): a tolerance 100× smaller
  // gives about 21× less error with 4.6× the steps (observed: 16.7× with 4.4×). The history is read at the output grid
  // (every 0.01 s) between steps of up to 0.1 s, by cubic Hermite interpolation, whose O(H⁴)
  // error stays below the step's own.
  std::vector<double> errors, steps;
  for (const char* tolerance : {"1e-4", "1e-6"}) {
    MultibodySimulation sim(interface::ScenarioFile::Parse(
        kOscillator, "oscillator.pbtxt",
        {"numerics.adaptive.enabled=true", std::string("numerics.adaptive.relative=") + tolerance,
         std::string("numerics.adaptive.absolute=") + tolerance, "numerics.adaptive.max_step=0.1"}));
    const Outputs r = Drive(&sim, 0.0, 2.0, 0.01, 0);
    double error = 0.0;
    for (size_t k = 0; k < r.time.size(); ++k)
      error = std::max(error, std::abs(r.value[k] - 0.1 * std::cos(10.0 * r.time[k])));
    std::printf("oscillator, tolerance %s: %.0f steps (%.0f rejected), max error %.3e m on the 0.01 s grid\n",
                tolerance, r.accepted, r.rejected, error);
    errors.push_back(error);
    steps.push_back(r.accepted);
  }
  // The same oscillator with fixed steps of the output grid's 0.01 s (200 steps): the phase error
  // of the second-order scheme, (ωh)²/12 per radian, is what the adaptive run's is made of.
  MultibodySimulation fixed(interface::ScenarioFile::Parse(kOscillator, "oscillator.pbtxt", {}));
  const Outputs f = Drive(&fixed, 0.0, 2.0, 0.01, 0);
  double fixed_error = 0.0;
  for (size_t k = 0; k < f.time.size(); ++k)
    fixed_error = std::max(fixed_error, std::abs(f.value[k] - 0.1 * std::cos(10.0 * f.time[k])));
  std::printf("oscillator, fixed steps of 0.01 s: 200 steps, max error %.3e m\n", fixed_error);
  EXPECT_GT(errors[0] / errors[1], 10.0);
  EXPECT_LT(errors[0] / errors[1], 50.0);
  EXPECT_GT(steps[1] / steps[0], 3.0);
  EXPECT_LT(steps[1] / steps[0], 7.0);
  // At a comparable number of steps the adaptive run is as accurate as the fixed one (no event
  // to concentrate the steps on: the error of a steady oscillation is spread evenly).
  EXPECT_LT(errors[1] * (steps[1] / 200.0) * (steps[1] / 200.0), 1.5 * fixed_error);
}

TEST(AdaptiveStep, APendulumAgainstAStopMatchesFineFixedStepsWithATwentiethOfTheSteps) {
  // scenarios/pendulum_stop_continuous.pbtxt: a 0.1 ms Hunt–Crossley impact at 0.503 s in a 1.5 s
  // swing. Fixed steps must resolve the impact everywhere; the adaptive step shortens towards the
  // stop (half the time to contact at the closing speed, then contact_step), through the impact by
  // its error estimate, and grows again after it. Observed (tolerance 1e-8, output every 0.5 ms):
  // 1296 steps, hinge angle after the impact within 3.3e-4 rad of h = 1e-5 s, where fixed
  // h = 2.5e-5 s (60000 steps) is within 5.3e-4 rad: 16× faster (0.094 s against 1.48 s).
  const std::string path = std::string(COSIM_SOURCE_DIR) + "/scenarios/pendulum_stop_continuous.pbtxt";
  MultibodySimulation fixed(interface::ScenarioFile::Load(path, {"numerics.step=2.5e-5"}));
  MultibodySimulation adaptive(interface::ScenarioFile::Load(
      path, {"numerics.step=5e-4", "numerics.adaptive.enabled=true", "numerics.adaptive.relative=1e-8",
             "numerics.adaptive.absolute=1e-8", "numerics.adaptive.contact_step=1e-5"}));
  const int angle = 2;  // hinge_angle
  const Outputs f = Drive(&fixed, 0.0, 1.5, 2.5e-5, angle);
  const Outputs a = Drive(&adaptive, 0.0, 1.5, 5e-4, angle);
  double difference = 0.0;
  for (size_t k = 0; k < a.time.size(); ++k) {
    const size_t j = 20 * k + 19;  // the fixed run's row at the same time
    ASSERT_NEAR(f.time[j], a.time[k], 1e-12);
    if (a.time[k] > 0.6) difference = std::max(difference, std::abs(f.value[j] - a.value[k]));
  }
  std::printf(
      "pendulum against a stop: adaptive %.0f steps (%.0f rejected) against 60000 fixed; hinge angle after "
      "the impact within %.2e rad\n",
      a.accepted, a.rejected, difference);
  EXPECT_LT(a.accepted, 60000.0 / 20.0);
  EXPECT_LT(difference, 1.5e-3);  // the two runs' own errors, 3.3e-4 and 5.3e-4, with margin
}

// CGα's steps, counted: every try ends in one acceptance or one rejection, and only the stepper
// touches the integrator's state.
class CountingStepper final : public Stepper {
 public:
  explicit CountingStepper(CgAlpha* cg) : inner_(cg) {}
  [[nodiscard]] StepAttempt TryStep(double t, double h) override {
    EXPECT_FALSE(open_) << "a try before the last one was accepted or rejected";
    open_ = true;
    ++tries;
    return inner_.TryStep(t, h);
  }
  void Accept(double t, double h) override {
    EXPECT_TRUE(open_);
    open_ = false;
    ++accepts;
    inner_.Accept(t, h);
  }
  void Reject() override {
    EXPECT_TRUE(open_);
    open_ = false;
    ++rejects;
    inner_.Reject();
  }
  [[nodiscard]] std::string WhyFailed() const override { return inner_.WhyFailed(); }
  const CgAlpha& integrator() const override { return inner_.integrator(); }
  const CgAlpha::Checkpoint& start() const override { return inner_.start(); }
  int tries = 0, accepts = 0, rejects = 0;

 private:
  CgAlphaStepper inner_;
  bool open_ = false;
};

TEST(AdaptiveStep, TheControllerDrivesAStepperThatOwnsTheStepsCheckpoint) {
  // Issue 52, item 2: the controller tried CGα's step through four hooks and saved and restored
  // the integrator itself, beside the coordinator's own checkpoint (two saves and two restores
  // per rejected coupled step). Now it drives a Stepper, which saves the step's start once and
  // undoes a rejected step: every try ends in exactly one Accept or Reject, the run's counts are
  // the stepper's, and the run through the counting stepper is the run through its own.
  const std::string path = std::string(COSIM_SOURCE_DIR) + "/scenarios/pendulum_stop_continuous.pbtxt";
  const std::vector<std::string> sets{"numerics.step=5e-3", "numerics.adaptive.enabled=true",
                                      "numerics.adaptive.relative=1e-5"};
  MultibodySimulation counted(interface::ScenarioFile::Load(path, sets));
  MultibodySimulation own(interface::ScenarioFile::Load(path, sets));
  CountingStepper stepper(counted.cgalpha());
  std::vector<double> a(counted.ProbeNames().size()), b(a.size());
  for (int k = 0; k < 300; ++k) {
    const double t = 5e-3 * k;
    counted.Advance(t + 5e-3, stepper);
    own.Step(t, 5e-3);
    counted.Probe(&a);
    own.Probe(&b);
    ASSERT_EQ(a, b) << "at t = " << t + 5e-3;
  }
  run::RunSummary summary;
  counted.FillSummary(&summary);
  EXPECT_GT(stepper.rejects, 0);  // the impact's steps are rejected and tried again smaller
  EXPECT_EQ(stepper.tries, stepper.accepts + stepper.rejects);
  EXPECT_EQ(summary.counters().at("adaptive_accepted_steps"), stepper.accepts);
  EXPECT_EQ(summary.counters().at("adaptive_rejected_steps"), stepper.rejects);
}

TEST(AdaptiveStep, AStepBelowTheMinimumEndsTheRunAsANumericalFailure) {
  // The 0.1 ms impact cannot be passed with steps of at least 1 ms: rejected down to min_step,
  // then NumericalError (exit 3 in a run, which keeps its outputs up to the last accepted step).
  const std::string path = std::string(COSIM_SOURCE_DIR) + "/scenarios/pendulum_stop_continuous.pbtxt";
  MultibodySimulation sim(interface::ScenarioFile::Load(
      path, {"numerics.step=5e-3", "numerics.adaptive.enabled=true", "numerics.adaptive.relative=1e-6",
             "numerics.adaptive.absolute=1e-6", "numerics.adaptive.min_step=1e-3"}));
  try {
    Drive(&sim, 0.0, 1.5, 5e-3, 0);
    FAIL() << "passed the impact with steps of at least 1 ms";
  } catch (const NumericalError& e) {
    EXPECT_NE(std::string(e.what()).find("min_step"), std::string::npos) << e.what();
  }
}

TEST(AdaptiveStep, SettingsItCannotHonourAreRefusedWithTheirPlace) {
  const std::vector<std::vector<std::string>> bad{
      {"numerics.adaptive.enabled=true", "numerics.smooth.integrator=IDA"},
      {"numerics.adaptive.enabled=true", "numerics.adaptive.min_step=1e-2", "numerics.adaptive.max_step=1e-3"},
      {"numerics.adaptive.enabled=true", "numerics.adaptive.relative=0"},
      {"numerics.adaptive.enabled=true", "numerics.adaptive.resting_speed=-1"},
  };
  for (const auto& sets : bad) {
    try {
      MultibodySimulation sim(interface::ScenarioFile::Parse(kOscillator, "oscillator.pbtxt", sets));
      ADD_FAILURE() << "accepted " << sets.back();
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("numerics.adaptive"), std::string::npos) << e.what();
    }
  }
}

TEST(AdaptiveStep, ARejectedStepLeavesNoTraceInTheContactMemory) {
  // The contact law's impact speed δ̇⁻ is part of the run's SystemData, which CGα's checkpoint
  // saves: a step that is tried, its state accepted into the memory and then rolled back (as the
  // adaptive loop and a coupling iteration do) restores the memory with the state. Before the
  // model/data split the memory lived in the contact element, where a rollback could not reach.
  MultibodySimulation sim(
      interface::ScenarioFile::Load(std::string(COSIM_SOURCE_DIR) + "/scenarios/pendulum_stop_continuous.pbtxt", {}));
  CgAlpha& cg = *sim.cgalpha();
  for (int k = 0; k < 100; ++k) sim.Step(k * 1e-3, 1e-3);  // swinging down: approaching the stop
  const double before = sim.data().impact_speed.at(0);
  CgAlpha::Checkpoint checkpoint;
  cg.SaveTo(&checkpoint);
  cg.Step(0.1, 0.05);  // a long step, then its end state "accepted" into the memory
  for (const auto& element : sim.system().forces)
    element->AcceptStep(cg.state().q, cg.state().qdot, 0.15, sim.mutable_data());
  const double tried = sim.data().impact_speed.at(0);
  EXPECT_GT(std::abs(tried - before), 0.1) << "the tried step should have changed the approach speed";
  cg.Restore(checkpoint);
  EXPECT_EQ(sim.data().impact_speed.at(0), before);
  EXPECT_EQ(cg.state().q, checkpoint.state.q);
}

}  // namespace
}  // namespace cosim::smooth
