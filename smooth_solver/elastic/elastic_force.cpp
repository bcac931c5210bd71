#include "smooth_solver/elastic/elastic_force.h"

namespace cosim::smooth {

void ElasticForce::AddForce(const Eigen::VectorXd& q, const Eigen::VectorXd&, double,
                            Eigen::Ref<Eigen::VectorXd> f) const {
  Eigen::VectorXd f_int;
  body_->Assemble(Positions(q), &f_int, nullptr);
  f.segment(offset_, f_int.size()) -= f_int;
}

void ElasticForce::AddTangent(const Eigen::VectorXd& q, const Eigen::VectorXd&, double, double stiffness_scale, double,
                              SparseSink* sink) const {
  if (stiffness_scale == 0.0) return;  // no damping in the material law
  Eigen::VectorXd f_int;
  Eigen::SparseMatrix<double> K;
  body_->Assemble(Positions(q), &f_int, &K);
  for (int k = 0; k < K.outerSize(); ++k) {
    for (Eigen::SparseMatrix<double>::InnerIterator it(K, k); it; ++it) {
      sink->Add(offset_ + static_cast<int>(it.row()), offset_ + static_cast<int>(it.col()), stiffness_scale * it.value());
    }
  }
}

void ElasticForce::Pattern(SparseSink* sink) const {
  for (const auto& element : body_->mesh().elements) {
    for (int a : element) {
      for (int b : element) {
        for (int i = 0; i < 3; ++i) {
          for (int j = 0; j < 3; ++j) sink->Add(offset_ + 3 * a + i, offset_ + 3 * b + j, 0.0);
        }
      }
    }
  }
}

double ElasticForce::PotentialEnergy(const Eigen::VectorXd& q) const { return body_->StrainEnergy(Positions(q)); }

}  // namespace cosim::smooth
