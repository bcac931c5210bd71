#pragma once
// The elastic bodies' internal force as the CGα integrators' end-point equations see it
// [CGα paper, Eqs. (12), (27)-(30)].
//
// Eq. (30) replaces the generalised-α average (1 − αf) f_int(q_{n+1}) + αf f_int(q_n) of
// Eq. (27) with the GEMM midpoint force f_m(q_n, q_{n+1}) of Eq. (13). With the constant mass
// matrix of natural coordinates (I_T = I in Eq. (26)), Eq. (30) is exactly the Arnold–Brüls
// scheme — end-point equations M q̈_{n+1} + f̃_{n+1} − f_{n+1} + Φ_qᵀλ_{n+1} = 0 plus the
// a-recursion of Eq. (3) — with an end-point internal force f̃ defined by
//   (1 − αf) f̃_{n+1} + αf f̃_n = f_m(q_n, q_{n+1}),   f̃_0 = f_int(q_0).
// (Multiply the end-point equations at n+1 and n by 1 − αf and αf, add them and use Eq. (3):
// that is Eq. (30) with I_T = I.) So the integrators keep their end-point form and this class
// carries f̃_n from step to step. With `gemm` false f̃ = f_int(q_{n+1}), the generalised-α force
// of Eq. (12).
#include <Eigen/Core>

#include "smooth_solver/model/multibody_system.h"

namespace cosim::smooth {

class ElasticStepForce {
 public:
  ElasticStepForce(const MultibodySystem& system, bool gemm, double alpha_f);

  bool empty() const { return system_.elastic_forces.empty(); }
  // Restarts the history at q: f̃_n = f_int(q) (the start, or a joint release).
  void Reset(const Eigen::VectorXd& q);
  // For the step q_prev → q: f −= f̃_{n+1}(q) and, if sink is given,
  // sink += k_scale · ∂f̃_{n+1}/∂q = k_scale/(1 − αf) · ∂f_m/∂q.
  void Add(const Eigen::VectorXd& q_prev, const Eigen::VectorXd& q, Eigen::Ref<Eigen::VectorXd> f, double k_scale,
           SparseSink* sink);
  // The step q_prev → q is accepted: f̃_n = f̃_{n+1}(q), evaluated at the accepted q.
  void Accept(const Eigen::VectorXd& q_prev, const Eigen::VectorXd& q);
  const Eigen::VectorXd& current() const { return current_; }   // f̃_n
  void set_current(const Eigen::VectorXd& f) { current_ = f; }  // a checkpoint's f̃_n

 private:
  void Evaluate(const Eigen::VectorXd& q_prev, const Eigen::VectorXd& q, double k_scale, SparseSink* sink);

  const MultibodySystem& system_;
  double alpha_;                    // αf with GEMM, 0 without
  Eigen::VectorXd current_, next_;  // f̃_n, f̃_{n+1}
};

}  // namespace cosim::smooth
