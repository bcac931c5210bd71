#include "smooth_solver/elastic/elastic_force.h"

namespace cosim::smooth {

void ElasticForce::AddMidpoint(const Eigen::VectorXd& q_prev, const Eigen::VectorXd& q, double alpha_f,
                               Eigen::Ref<Eigen::VectorXd> f_m, SparseSink* sink, double k_scale) const {
  const MidpointWeights weights{alpha_f, alpha_f == 0.0 ? 0.0 : strain_damping_};
  body_->AssembleMidpoint(Positions(q_prev), Positions(q), weights, 1.0, f_m.segment(offset_, 3 * body_->node_count()),
                          k_scale, sink, offset_);
}

void ElasticForce::AddForce(const Eigen::VectorXd& q, const Eigen::VectorXd&, double, const SystemData&,
                            Eigen::Ref<Eigen::VectorXd> f) const {
  body_->AssembleMidpoint(Positions(q), Positions(q), MidpointWeights{}, -1.0,
                          f.segment(offset_, 3 * body_->node_count()), 0.0, nullptr, offset_);
}

void ElasticForce::AddTangent(const Eigen::VectorXd& q, const Eigen::VectorXd&, double, const SystemData&,
                              double stiffness_scale, double, SparseSink* sink) const {
  if (stiffness_scale == 0.0) return;  // no damping in the material law
  Eigen::VectorXd unused(0);           // f_scale = 0: the force is not assembled
  body_->AssembleMidpoint(Positions(q), Positions(q), MidpointWeights{}, 0.0, unused, stiffness_scale, sink, offset_);
}

void ElasticDamping::AddForce(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double, const SystemData&,
                              Eigen::Ref<Eigen::VectorXd> f) const {
  body_->AssembleViscous(Nodes(q), Nodes(qdot), retardation_, -1.0, f.segment(offset_, 3 * body_->node_count()), 0.0,
                         0.0, nullptr, offset_);
}

void ElasticDamping::AddTangent(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double, const SystemData&,
                                double stiffness_scale, double damping_scale, SparseSink* sink) const {
  if (stiffness_scale == 0.0 && damping_scale == 0.0) return;
  Eigen::VectorXd unused(0);
  body_->AssembleViscous(Nodes(q), Nodes(qdot), retardation_, 0.0, unused, stiffness_scale, damping_scale, sink,
                         offset_);
}

void ElasticDamping::Pattern(SparseSink* sink) const { ElasticPattern(*body_, offset_, sink); }

void ElasticForce::Pattern(SparseSink* sink) const { ElasticPattern(*body_, offset_, sink); }

void ElasticPattern(const ElasticBody& body, int offset, SparseSink* sink) {
  for (const auto& element : body.mesh().elements) {
    for (int a : element) {
      for (int b : element) {
        for (int i = 0; i < 3; ++i) {
          for (int j = 0; j < 3; ++j) sink->Add(offset + 3 * a + i, offset + 3 * b + j, 0.0);
        }
      }
    }
  }
}

double ElasticForce::PotentialEnergy(const Eigen::VectorXd& q) const { return body_->StrainEnergy(Positions(q)); }

}  // namespace cosim::smooth
