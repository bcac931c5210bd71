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

namespace {

using Columns = Eigen::Matrix<double, 3, Hex27::kNodes>;
using NodeNode = Eigen::Matrix<double, Hex27::kNodes, Hex27::kNodes>;

// The tangent blocks are accumulated component-major, Kc(27 i + a, 27 j + b) = K(3a + i, 3b + j),
// so that each column of each of the nine 27×27 blocks is 27 contiguous entries.
//
// The derivative of ∫ A S ∇N_a with S = C : sym(Bᵀ δF) along δF = e_j ∇N_bᵀ:
//   λ (A∇N_a)_i (B∇N_b)_j + μ [(∇N_a·∇N_b)(A Bᵀ)_ij + (A∇N_b)_i (B∇N_a)_j],
// with U = A G, V = B G (columns A∇N_a, B∇N_a) and GtG = ∇N_a·∇N_b, all weights included;
// plus, on the diagonal blocks, the geometric part GSG(a, b) = ∇N_a · S ∇N_b (if given).
// One fused pass over the element matrix per Gauss point (two rank-1 terms, the scaled GtG and
// the geometric term in one loop the compiler vectorises): separate Eigen expressions for each
// term went through the 52 kB matrix three times per point (elastic_benchmark: 300 µs per
// element against the force's 9 µs).
void AddMaterialBlocks(const Columns& U, const Columns& V, double wl, double wm, const NodeNode& GtG,
                       const Eigen::Matrix3d& ABt, const NodeNode* GSG, Hex27::ElementMatrix* Kc) {
  constexpr int n = Hex27::kNodes, rows = 3 * n;
  alignas(32) double Ut[3][n], Vt[3][n];  // rows of U and V, contiguous
  for (int a = 0; a < n; ++a) {
    for (int i = 0; i < 3; ++i) Ut[i][a] = U(i, a), Vt[i][a] = V(i, a);
  }
  double* K = Kc->data();
  for (int j = 0; j < 3; ++j) {
    for (int i = 0; i < 3; ++i) {
      const double c = wm * ABt(i, j);
      const double* ui = Ut[i];
      const double* vj = Vt[j];
      for (int b = 0; b < n; ++b) {
        double* __restrict col = K + (n * j + b) * rows + n * i;
        const double vb = wl * vj[b], ub = wm * ui[b];
        const double* __restrict g = GtG.data() + n * b;
        if (GSG != nullptr && i == j) {
          const double* __restrict s = GSG->data() + n * b;
          for (int a = 0; a < n; ++a) col[a] += ui[a] * vb + vj[a] * ub + c * g[a] + s[a];
        } else {
          for (int a = 0; a < n; ++a) col[a] += ui[a] * vb + vj[a] * ub + c * g[a];
        }
      }
    }
  }
}

// out = Aᵀ B for 3 × 27 operands, as three outer products of rows (contiguous columns of out;
// Eigen's blocked product costs more at an inner dimension of 3).
void GramOf(const Columns& A, const Columns& B, NodeNode* out) {
  out->noalias() = A.row(0).transpose() * B.row(0);
  out->noalias() += A.row(1).transpose() * B.row(1);
  out->noalias() += A.row(2).transpose() * B.row(2);
}

void NodeMajor(const Hex27::ElementMatrix& Kc, Hex27::ElementMatrix* K) {
  constexpr int n = Hex27::kNodes;
  for (int b = 0; b < n; ++b) {
    for (int j = 0; j < 3; ++j) {
      for (int a = 0; a < n; ++a) {
        for (int i = 0; i < 3; ++i) (*K)(3 * a + i, 3 * b + j) = Kc(n * i + a, n * j + b);
      }
    }
  }
}

Eigen::Matrix3d StVenantKirchhoff(const ElasticMaterial& m, const Eigen::Matrix3d& E) {
  return m.lambda() * E.trace() * Eigen::Matrix3d::Identity() + 2.0 * m.mu() * E;
}

}  // namespace

void Hex27::MidpointForce(const ElasticMaterial& m, const NodeMatrix& x_prev, const NodeMatrix& x, MidpointWeights mw,
                          ElementVector* f, ElementMatrix* K) const {
  const double c_geometric = 1.0 - mw.alpha_f, c_material = 1.0 - mw.alpha_f + mw.xi;
  const bool same = mw.alpha_f == 0.0 && mw.xi == 0.0;  // end-point force: x_prev unused
  if (f != nullptr) f->setZero();
  ElementMatrix Kc;  // component-major accumulator (52 kB on the stack)
  NodeNode GSG, GtG;
  if (K != nullptr) Kc.setZero();
  const NodeMatrix u1 = x - reference_;
  const NodeMatrix u0 = same ? u1 : NodeMatrix(x_prev - reference_);
  for (size_t g = 0; g < kGauss; ++g) {
    const auto& G = grad_[g];
    const double w = weight_[g];
    const Eigen::Matrix3d H1 = u1.lazyProduct(G.transpose());
    const Eigen::Matrix3d E1 = 0.5 * (H1 + H1.transpose() + H1.transpose() * H1);
    Eigen::Matrix3d Hm = H1, Em = E1;
    if (!same) {
      const Eigen::Matrix3d H0 = u0.lazyProduct(G.transpose());
      const Eigen::Matrix3d E0 = 0.5 * (H0 + H0.transpose() + H0.transpose() * H0);
      Hm = (1.0 - mw.alpha_f) * H1 + mw.alpha_f * H0;                    // Eq. (15)
      Em = (1.0 - mw.alpha_f + mw.xi) * E1 + (mw.alpha_f - mw.xi) * E0;  // Eqs. (16)-(17)
    }
    const Eigen::Matrix3d F1 = Eigen::Matrix3d::Identity() + H1;
    const Eigen::Matrix3d Fm = Eigen::Matrix3d::Identity() + Hm;
    const Eigen::Matrix3d S = StVenantKirchhoff(m, Em);
    if (f != nullptr) {
      const Columns P = Eigen::Matrix3d(w * Fm * S).lazyProduct(G);  // column a: F_m S_m ∇N_a
      f->noalias() += Eigen::Map<const ElementVector>(P.data());
    }
    if (K != nullptr) {
      GramOf(G, Columns(Eigen::Matrix3d((w * c_geometric) * S).lazyProduct(G)), &GSG);
      GramOf(G, G, &GtG);
      const double wc = w * c_material;
      AddMaterialBlocks(Fm.lazyProduct(G), F1.lazyProduct(G), wc * m.lambda(), wc * m.mu(), GtG, Fm * F1.transpose(),
                        &GSG, &Kc);
    }
  }
  if (K != nullptr) NodeMajor(Kc, K);
}

void Hex27::ViscousForce(const ElasticMaterial& m, double retardation, const NodeMatrix& x, const NodeMatrix& v,
                         ElementVector* f, double k_scale, double c_scale, ElementMatrix* KC) const {
  if (f != nullptr) f->setZero();
  ElementMatrix Kc;
  NodeNode GSG, GtG;
  if (KC != nullptr) Kc.setZero();
  const NodeMatrix u = x - reference_;
  for (size_t g = 0; g < kGauss; ++g) {
    const auto& G = grad_[g];
    const double w = weight_[g];
    const Eigen::Matrix3d F = Eigen::Matrix3d::Identity() + u.lazyProduct(G.transpose());
    const Eigen::Matrix3d Fdot = v.lazyProduct(G.transpose());
    const Eigen::Matrix3d Edot = 0.5 * (F.transpose() * Fdot + Fdot.transpose() * F);
    const Eigen::Matrix3d S = retardation * StVenantKirchhoff(m, Edot);  // S_v = β C : Ė
    if (f != nullptr) {
      const Columns P = Eigen::Matrix3d(w * F * S).lazyProduct(G);
      f->noalias() += Eigen::Map<const ElementVector>(P.data());
    }
    if (KC == nullptr) continue;
    // ∂/∂v through Ḟ (B = F) and ∂/∂x through Ė's F (B = Ḟ): one material block with
    // B = k_scale Ḟ + c_scale F; and ∂/∂x through F S_v, the geometric part.
    GramOf(G, G, &GtG);
    const Eigen::Matrix3d B = k_scale * Fdot + c_scale * F;
    if (k_scale != 0.0) GramOf(G, Columns(Eigen::Matrix3d((k_scale * w) * S).lazyProduct(G)), &GSG);
    AddMaterialBlocks(F.lazyProduct(G), B.lazyProduct(G), w * retardation * m.lambda(), w * retardation * m.mu(), GtG,
                      F * B.transpose(), k_scale != 0.0 ? &GSG : nullptr, &Kc);
  }
  if (KC != nullptr) NodeMajor(Kc, KC);
}

double Hex27::StrainEnergy(const ElasticMaterial& m, const NodeMatrix& x) const {
  double energy = 0.0;
  for (size_t g = 0; g < kGauss; ++g) {
    const Eigen::Matrix3d H = NodeMatrix(x - reference_).lazyProduct(grad_[g].transpose());
    const Eigen::Matrix3d E = 0.5 * (H + H.transpose() + H.transpose() * H);
    energy += weight_[g] * (0.5 * m.lambda() * E.trace() * E.trace() + m.mu() * (E.array() * E.array()).sum());
  }
  return energy;
}

double Hex27::VonMisesStress(const ElasticMaterial& m, const NodeMatrix& x) const {
  double integral = 0.0, volume = 0.0;
  for (size_t g = 0; g < kGauss; ++g) {
    const Eigen::Matrix3d H = NodeMatrix(x - reference_).lazyProduct(grad_[g].transpose());
    const Eigen::Matrix3d E = 0.5 * (H + H.transpose() + H.transpose() * H);
    const Eigen::Matrix3d F = Eigen::Matrix3d::Identity() + H;
    const Eigen::Matrix3d sigma = F * StVenantKirchhoff(m, E) * F.transpose() / F.determinant();  // Cauchy
    const Eigen::Matrix3d deviator = sigma - sigma.trace() / 3.0 * Eigen::Matrix3d::Identity();
    integral += weight_[g] * std::sqrt(1.5 * (deviator.array() * deviator.array()).sum());
    volume += weight_[g];
  }
  return integral / volume;
}

}  // namespace cosim::smooth
