#pragma once
// An elastic body inside the multibody equations: its node positions are coordinates of
// the system (from `offset`, 3 per node), its consistent mass joins the constant mass matrix,
// and its internal force enters as the force element −f_int(x) with the tangent K_int.
// (This is the generalised-α end-point force; the GEMM midpoint force of the CGα paper,
// Eqs. (13)-(19), is the next step of issue 5.)
#include "smooth_solver/elastic/elastic_body.h"
#include "smooth_solver/forces/force_elements.h"

namespace cosim::smooth {

class ElasticForce : public ForceElement {
 public:
  ElasticForce(const ElasticBody* body, int offset) : body_(body), offset_(offset) {}
  void AddForce(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t,
                Eigen::Ref<Eigen::VectorXd> f) const override;
  void AddTangent(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, double stiffness_scale,
                  double damping_scale, SparseSink* sink) const override;
  void Pattern(SparseSink* sink) const override;
  double PotentialEnergy(const Eigen::VectorXd& q) const override;

 private:
  Eigen::Matrix3Xd Positions(const Eigen::VectorXd& q) const {
    return Eigen::Map<const Eigen::Matrix3Xd>(q.data() + offset_, 3, body_->node_count());
  }
  const ElasticBody* body_;
  int offset_;
};

}  // namespace cosim::smooth
