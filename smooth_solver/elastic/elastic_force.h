#pragma once
// An elastic body inside the multibody equations: its node positions are coordinates of
// the system (from `offset`, 3 per node), its consistent mass joins the constant mass matrix,
// and its internal force enters as the force element −f_int(x) with the tangent K_int (the
// end-point force, as IDA and the static analysis use it). The CGα integrator instead asks for
// the GEMM midpoint force over its step (AddMidpoint, Eqs. (13)-(19)).
#include <utility>

#include "interface/scenario/time_function.h"
#include "smooth_solver/elastic/elastic_body.h"
#include "smooth_solver/forces/force_elements.h"

namespace cosim::smooth {

// Every (row, column) the element matrices of `body` touch, its coordinates from `offset`.
void ElasticPattern(const ElasticBody& body, int offset, SparseSink* sink);

class ElasticForce : public ForceElement {
 public:
  ElasticForce(const ElasticBody* body, int offset, double strain_damping)
      : body_(body), offset_(offset), strain_damping_(strain_damping) {}
  void AddForce(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, const SystemData& data,
                Eigen::Ref<Eigen::VectorXd> f) const override;
  void AddTangent(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, const SystemData& data,
                  double stiffness_scale, double damping_scale, SparseSink* sink) const override;
  void Pattern(SparseSink* sink) const override;
  double PotentialEnergy(const Eigen::VectorXd& q) const override;
  bool IsElastic() const override { return true; }

  // f_m += the midpoint internal force over q_prev → q with weights (αf, ξ of this body) —
  // αf = 0 gives the end-point force f_int(q), whatever ξ — and, if sink is given,
  // sink += k_scale · ∂f_m/∂q.
  void AddMidpoint(const Eigen::VectorXd& q_prev, const Eigen::VectorXd& q, double alpha_f,
                   Eigen::Ref<Eigen::VectorXd> f_m, SparseSink* sink, double k_scale) const;

 private:
  Eigen::Map<const Eigen::Matrix3Xd> Positions(const Eigen::VectorXd& q) const { return body_->NodesIn(q, offset_); }
  const ElasticBody* body_;
  int offset_;
  double strain_damping_;
};

// Kelvin–Voigt structural damping of an elastic body (retardation time β): the force element
// −f_v(x, ẋ) with both tangents. An ordinary end-point force for the integrators.
class ElasticDamping : public ForceElement {
 public:
  ElasticDamping(const ElasticBody* body, int offset, double retardation)
      : body_(body), offset_(offset), retardation_(retardation) {}
  void AddForce(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, const SystemData& data,
                Eigen::Ref<Eigen::VectorXd> f) const override;
  void AddTangent(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, const SystemData& data,
                  double stiffness_scale, double damping_scale, SparseSink* sink) const override;
  void Pattern(SparseSink* sink) const override;

 private:
  Eigen::Map<const Eigen::Matrix3Xd> Nodes(const Eigen::VectorXd& q) const { return body_->NodesIn(q, offset_); }
  const ElasticBody* body_;
  int offset_;
  double retardation_;
};

// A force on one coordinate triple (an elastic body's node): F factor(t), global frame. With a
// constant factor it is conservative, V = −factor F · (x − X); with a time-varying one it has no
// potential and the TOTAL_ENERGY probe does not count its work.
class NodalForce : public ForceElement {
 public:
  NodalForce(int index, const Eigen::Vector3d& reference, const Eigen::Vector3d& force, interface::TimeFunction factor,
             bool time_varying)
      : index_(index), reference_(reference), force_(force), factor_(std::move(factor)), time_varying_(time_varying) {}
  void AddForce(const Eigen::VectorXd&, const Eigen::VectorXd&, double t, const SystemData&,
                Eigen::Ref<Eigen::VectorXd> f) const override {
    f.segment<3>(index_) += factor_.Value(t) * force_;
  }
  void AddTangent(const Eigen::VectorXd&, const Eigen::VectorXd&, double, const SystemData&, double, double,
                  SparseSink*) const override {}
  void Pattern(SparseSink*) const override {}
  double PotentialEnergy(const Eigen::VectorXd& q) const override {
    return time_varying_ ? 0.0 : -factor_.Value(0.0) * force_.dot(q.segment<3>(index_) - reference_);
  }
  bool Passive() const override { return !time_varying_; }

 private:
  int index_;
  Eigen::Vector3d reference_, force_;
  interface::TimeFunction factor_;
  bool time_varying_;
};

}  // namespace cosim::smooth
