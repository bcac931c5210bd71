#pragma once
// The step that numerics.adaptive's controller (simulation/adaptive_step.h) drives: tried from
// the state at its start, judged on its error estimate, then kept or undone. CGα alone
// (CgAlphaStepper) and the coordinator of a coupled run (the smooth step with the contact
// processes' answers) implement it. The stepper saves the step's start once, and undoes a
// rejected step from it; the controller reads that checkpoint (the error estimate, the
// interpolation) but keeps none of its own.
#include <limits>
#include <string>

#include "smooth_solver/integrator/cgalpha.h"

namespace cosim::smooth {

// What one try of a step tells the controller.
struct StepAttempt {
  int iterations = 0;   // Newton iterations (for the statistics)
  bool failed = false;  // the step failed (Newton, coupling): rejected, and WhyFailed says why
  bool impact = false;  // a contact process's contact closed in the step: no error test
  double time_to_contact = std::numeric_limits<double>::infinity();  // the peers', from its end [s]
};

class Stepper {
 public:
  virtual ~Stepper() = default;
  // The step from t to t + h, from the state at t (saved first, as start()).
  [[nodiscard]] virtual StepAttempt TryStep(double t, double h) = 0;
  // The last try kept (before the run records it), or undone: the state back at start().
  virtual void Accept(double t, double h) = 0;
  virtual void Reject() = 0;
  // Why the last try failed, in the run's terms (asked before Reject, while its state is there).
  [[nodiscard]] virtual std::string WhyFailed() const = 0;
  // The CGα integrator stepped, and the step's start it saved.
  virtual const CgAlpha& integrator() const = 0;
  virtual const CgAlpha::Checkpoint& start() const = 0;
};

// CGα's own steps (a standalone run).
class CgAlphaStepper final : public Stepper {
 public:
  explicit CgAlphaStepper(CgAlpha* cg) : cg_(cg) {}
  [[nodiscard]] StepAttempt TryStep(double t, double h) override {
    cg_->SaveTo(&start_);
    last_ = cg_->TryStep(t, h);
    StepAttempt attempt;
    attempt.failed = !last_.ok();
    if (!attempt.failed) attempt.iterations = last_.iterations;
    return attempt;
  }
  void Accept(double /*t*/, double /*h*/) override {}
  void Reject() override { cg_->Restore(start_); }
  [[nodiscard]] std::string WhyFailed() const override { return last_.Describe(cg_->settings()); }
  const CgAlpha& integrator() const override { return *cg_; }
  const CgAlpha::Checkpoint& start() const override { return start_; }

 private:
  CgAlpha* cg_;
  CgAlpha::Checkpoint start_;
  StepStatus last_;
};

}  // namespace cosim::smooth
