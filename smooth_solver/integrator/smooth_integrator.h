#pragma once
// What a smooth-solver integrator offers the simulation: CGα (the method) and IDA (the
// independent reference) behind one interface.
#include "smooth_solver/model/multibody_system.h"

namespace cosim::smooth {

struct DaeState {
  Eigen::VectorXd q, qdot, qddot, lambda;
};

class SmoothIntegrator {
 public:
  virtual ~SmoothIntegrator() = default;
  // Advances from t to t + h; returns the nonlinear iterations used. Throws NumericalError
  // (state unchanged) on failure.
  virtual int Step(double t, double h) = 0;
  virtual const DaeState& state() const = 0;
  // |Φ(q, t)|∞ at the current state.
  virtual double ConstraintViolation(double t) const = 0;
};

}  // namespace cosim::smooth
