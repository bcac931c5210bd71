#include "smooth_solver/integrator/elastic_step_force.h"

namespace cosim::smooth {

ElasticStepForce::ElasticStepForce(const MultibodySystem& system, bool gemm, double alpha_f)
    : system_(system), alpha_(gemm ? alpha_f : 0.0) {
  current_ = Eigen::VectorXd::Zero(system.coordinates);
  next_ = current_;
}

void ElasticStepForce::Reset(const Eigen::VectorXd& q) {
  current_.setZero();
  for (const ElasticForce* e : system_.elastic_forces) e->AddMidpoint(q, q, 0.0, current_, nullptr, 0.0);
}

void ElasticStepForce::Evaluate(const Eigen::VectorXd& q_prev, const Eigen::VectorXd& q, double k_scale,
                                SparseSink* sink) {
  next_.setZero();
  const double c = 1.0 / (1.0 - alpha_);
  for (const ElasticForce* e : system_.elastic_forces) e->AddMidpoint(q_prev, q, alpha_, next_, sink, c * k_scale);
  if (alpha_ != 0.0) next_ = c * (next_ - alpha_ * current_);  // f̃_{n+1} = (f_m − αf f̃_n)/(1 − αf)
}

void ElasticStepForce::Add(const Eigen::VectorXd& q_prev, const Eigen::VectorXd& q, Eigen::Ref<Eigen::VectorXd> f,
                           double k_scale, SparseSink* sink) {
  if (empty()) return;
  Evaluate(q_prev, q, k_scale, sink);
  f -= next_;
}

void ElasticStepForce::Accept(const Eigen::VectorXd& q_prev, const Eigen::VectorXd& q) {
  if (empty()) return;
  Evaluate(q_prev, q, 0.0, nullptr);
  current_.swap(next_);
}

}  // namespace cosim::smooth
