#pragma once
// What a smooth-solver integrator offers the simulation: CGα (the method) and IDA (the
// independent reference) behind one interface.
#include "smooth_solver/model/multibody_system.h"

namespace cosim::smooth {

struct DaeState {
  Eigen::VectorXd q, qdot, qddot, lambda;
};

// What an integrator offers beyond Step, so that a run asks the integrator rather than its
// type: a checkpoint of a step's start, to try the step again and take it back (a coupled run's
// coupling iterations, a rejected adaptive step; CgAlpha::SaveTo, Restore and TryStep), and a
// local error estimate (the adaptive step's, on CGα's acceleration variable). IDA, the
// reference, offers neither: it chooses its own internal steps and keeps no step's start; nor
// does CGα with index-2 projection.
struct IntegratorCapabilities {
  bool checkpoints = false;
  bool error_estimate = false;
};

class SmoothIntegrator {
 public:
  virtual ~SmoothIntegrator() = default;
  virtual IntegratorCapabilities capabilities() const = 0;
  // Advances from t to t + h; returns the nonlinear iterations used. Throws NumericalError
  // (state unchanged) on failure.
  virtual int Step(double t, double h) = 0;
  virtual const DaeState& state() const = 0;
  // |Φ(q, t)|∞ at the current state.
  virtual double ConstraintViolation(double t) const = 0;
};

}  // namespace cosim::smooth
