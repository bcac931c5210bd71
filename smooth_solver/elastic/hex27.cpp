#include "smooth_solver/elastic/hex27.h"

#include <Eigen/LU>

#include <cmath>

namespace cosim::smooth {

namespace {

// 3-point Gauss–Legendre rule on [−1, 1].
constexpr std::array<double, 3> kPoint{-0.7745966692414834, 0.0, 0.7745966692414834};
constexpr std::array<double, 3> kWeight{5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};

}  // namespace

std::array<double, 3> Hex27::Shape1D(double s) { return {0.5 * s * (s - 1.0), 1.0 - s * s, 0.5 * s * (s + 1.0)}; }

std::array<double, 3> Hex27::Shape1DDerivative(double s) { return {s - 0.5, -2.0 * s, s + 0.5}; }

bool Hex27::Initialize(const NodeMatrix& reference) {
  reference_ = reference;
  int g = 0;
  for (int gk = 0; gk < 3; ++gk) {
    for (int gj = 0; gj < 3; ++gj) {
      for (int gi = 0; gi < 3; ++gi, ++g) {
        const double xi = kPoint[static_cast<size_t>(gi)], eta = kPoint[static_cast<size_t>(gj)],
                     zeta = kPoint[static_cast<size_t>(gk)];
        const auto Nx = Shape1D(xi), Ny = Shape1D(eta), Nz = Shape1D(zeta);
        const auto dx = Shape1DDerivative(xi), dy = Shape1DDerivative(eta), dz = Shape1DDerivative(zeta);
        Eigen::Matrix<double, 3, kNodes> dN_dxi;  // ∂N_a/∂(ξ, η, ζ)
        for (int k = 0; k < 3; ++k) {
          for (int j = 0; j < 3; ++j) {
            for (int i = 0; i < 3; ++i) {
              const int a = i + 3 * j + 9 * k;
              const size_t I = static_cast<size_t>(i), J = static_cast<size_t>(j), K = static_cast<size_t>(k);
              shape_[static_cast<size_t>(g)](a) = Nx[I] * Ny[J] * Nz[K];
              dN_dxi.col(a) << dx[I] * Ny[J] * Nz[K], Nx[I] * dy[J] * Nz[K], Nx[I] * Ny[J] * dz[K];
            }
          }
        }
        // J = ∂X/∂ξ (3×3); ∇_X N = J⁻ᵀ ∂N/∂ξ.
        const Eigen::Matrix3d J = reference * dN_dxi.transpose();
        const double det = J.determinant();
        if (!(det > 0.0) || !std::isfinite(det)) return false;
        grad_[static_cast<size_t>(g)] = J.transpose().inverse() * dN_dxi;
        weight_[static_cast<size_t>(g)] = kWeight[static_cast<size_t>(gi)] * kWeight[static_cast<size_t>(gj)] *
                                          kWeight[static_cast<size_t>(gk)] * det;
      }
    }
  }
  return true;
}

double Hex27::Volume() const {
  double v = 0.0;
  for (double w : weight_) v += w;
  return v;
}

Eigen::Matrix<double, Hex27::kNodes, Hex27::kNodes> Hex27::ScalarMass(double density) const {
  Eigen::Matrix<double, kNodes, kNodes> M = Eigen::Matrix<double, kNodes, kNodes>::Zero();
  for (size_t g = 0; g < kGauss; ++g) M.noalias() += density * weight_[g] * shape_[g] * shape_[g].transpose();
  return M;
}

void Hex27::InternalForce(const ElasticMaterial& m, const NodeMatrix& x, ElementVector* f, ElementMatrix* K) const {
  const double lambda = m.lambda(), mu = m.mu();
  if (f != nullptr) f->setZero();
  if (K != nullptr) K->setZero();
  for (size_t g = 0; g < kGauss; ++g) {
    const auto& G = grad_[g];
    const double w = weight_[g];
    const Eigen::Matrix3d H = (x - reference_) * G.transpose();
    const Eigen::Matrix3d F = Eigen::Matrix3d::Identity() + H;
    const Eigen::Matrix3d E = 0.5 * (H + H.transpose() + H.transpose() * H);
    const Eigen::Matrix3d S = lambda * E.trace() * Eigen::Matrix3d::Identity() + 2.0 * mu * E;
    const Eigen::Matrix<double, 3, kNodes> FG = F * G;  // column a: F ∇N_a
    if (f != nullptr) {
      const Eigen::Matrix<double, 3, kNodes> P = F * S * G;  // column a: F S ∇N_a
      for (int a = 0; a < kNodes; ++a) f->segment<3>(3 * a) += w * P.col(a);
    }
    if (K != nullptr) {
      const Eigen::Matrix<double, kNodes, kNodes> GSG = G.transpose() * S * G;  // ∇N_a · S ∇N_b
      const Eigen::Matrix<double, kNodes, kNodes> GtG = G.transpose() * G;    // ∇N_a · ∇N_b
      const Eigen::Matrix3d FFt = F * F.transpose();
      for (int b = 0; b < kNodes; ++b) {
        for (int a = 0; a < kNodes; ++a) {
          Eigen::Matrix3d block = lambda * FG.col(a) * FG.col(b).transpose() +
                                  mu * (GtG(a, b) * FFt + FG.col(b) * FG.col(a).transpose());
          block.diagonal().array() += GSG(a, b);
          K->block<3, 3>(3 * a, 3 * b) += w * block;
        }
      }
    }
  }
}

double Hex27::StrainEnergy(const ElasticMaterial& m, const NodeMatrix& x) const {
  double energy = 0.0;
  for (size_t g = 0; g < kGauss; ++g) {
    const Eigen::Matrix3d H = (x - reference_) * grad_[g].transpose();
    const Eigen::Matrix3d E = 0.5 * (H + H.transpose() + H.transpose() * H);
    energy += weight_[g] * (0.5 * m.lambda() * E.trace() * E.trace() + m.mu() * (E.array() * E.array()).sum());
  }
  return energy;
}

}  // namespace cosim::smooth
