#include "smooth_solver/beam/beam.h"

#include <algorithm>
#include <cmath>

#include "interface/base/errors.h"

namespace cosim::smooth {

namespace {

// Slot (0: x, 1: d1, 2: d2, 3: d3) of node I: first of its three local coordinates.
constexpr int Slot(int node, int slot) { return kCoordinatesPerBody * node + 3 * slot; }

BeamSection Lerp(const BeamSection& a, const BeamSection& b, double t) {
  auto mix = [t](double x, double y) { return x + t * (y - x); };
  BeamSection s;
  s.ea = mix(a.ea, b.ea);
  s.ga2 = mix(a.ga2, b.ga2);
  s.ga3 = mix(a.ga3, b.ga3);
  s.gj = mix(a.gj, b.gj);
  s.ei2 = mix(a.ei2, b.ei2);
  s.ei3 = mix(a.ei3, b.ei3);
  s.tension2 = mix(a.tension2, b.tension2);
  s.tension3 = mix(a.tension3, b.tension3);
  s.mass = mix(a.mass, b.mass);
  s.cg2 = mix(a.cg2, b.cg2);
  s.cg3 = mix(a.cg3, b.cg3);
  s.inertia2 = mix(a.inertia2, b.inertia2);
  s.inertia3 = mix(a.inertia3, b.inertia3);
  s.twist = mix(a.twist, b.twist);
  return s;
}

}  // namespace

Matrix6d SectionStiffness(const BeamSection& s) {
  // C = Tᵀ D T: T maps ε to [Γ1 + t3 κ2 − t2 κ3, Γ2, Γ3, κ1, κ2, κ3] (strains at the tension
  // centre), D = diag(EA, GA2, GA3, GJ, EI2, EI3) there.
  Matrix6d T = Matrix6d::Identity();
  T(0, 4) = s.tension3;
  T(0, 5) = -s.tension2;
  Vector6d d;
  d << s.ea, s.ga2, s.ga3, s.gj, s.ei2, s.ei3;
  return T.transpose() * d.asDiagonal() * T;
}

Eigen::Matrix2d SectionSecondMoments(const BeamSection& s) {
  // ∫ρ η_a η_b = (about the c.g.) + m c_a c_b; no product of inertia about the c.g.
  Eigen::Matrix2d J;
  J << s.inertia3 + s.mass * s.cg2 * s.cg2, s.mass * s.cg2 * s.cg3,  //
      s.mass * s.cg2 * s.cg3, s.inertia2 + s.mass * s.cg3 * s.cg3;
  return J;
}

BeamTable::BeamTable(std::vector<double> s, std::vector<BeamSection> sections)
    : s_(std::move(s)), sections_(std::move(sections)) {
  COSIM_ASSERT(!s_.empty() && s_.size() == sections_.size(), "beam table without stations");
  COSIM_ASSERT(std::is_sorted(s_.begin(), s_.end()), "beam stations out of order");
}

BeamSection BeamTable::At(double s, bool inboard) const {
  if (s <= s_.front()) return sections_.front();
  if (s >= s_.back()) return sections_.back();
  // k: the interval [s_k, s_{k+1}] of positive length holding s, on the chosen side of a step.
  const auto it = inboard ? std::lower_bound(s_.begin(), s_.end(), s) : std::upper_bound(s_.begin(), s_.end(), s);
  const size_t k = static_cast<size_t>(it - s_.begin()) - 1;
  const double t = (s - s_[k]) / (s_[k + 1] - s_[k]);
  return Lerp(sections_[k], sections_[k + 1], t);
}

std::vector<double> BeamTable::BreaksWithin(double a, double b) const {
  std::vector<double> out;
  for (double s : s_) {
    if (s > a && s < b && (out.empty() || out.back() != s)) out.push_back(s);
  }
  return out;
}

void BeamShape(int n, double xi, double* N, double* dN) {
  if (n == 2) {
    N[0] = 0.5 * (1.0 - xi);
    N[1] = 0.5 * (1.0 + xi);
    dN[0] = -0.5;
    dN[1] = 0.5;
  } else {
    N[0] = 0.5 * xi * (xi - 1.0);
    N[1] = 1.0 - xi * xi;
    N[2] = 0.5 * xi * (xi + 1.0);
    dN[0] = xi - 0.5;
    dN[1] = -2.0 * xi;
    dN[2] = xi + 0.5;
  }
}

int BeamGaussPoints(int n, std::array<double, 2>* xi, std::array<double, 2>* weight) {
  if (n == 2) {
    *xi = {0.0, 0.0};
    *weight = {2.0, 0.0};
    return 1;
  }
  const double g = 1.0 / std::sqrt(3.0);
  *xi = {-g, g};
  *weight = {1.0, 1.0};
  return 2;
}

BeamForce::BeamForce(std::string name, int nodes_per_element, std::vector<BeamElement> elements, double retardation)
    : name_(std::move(name)), n_(nodes_per_element), elements_(std::move(elements)), retardation_(retardation) {
  COSIM_ASSERT(n_ == 2 || n_ == 3, "beam elements have 2 or 3 nodes");
  gauss_ = BeamGaussPoints(n_, &xi_, &w_);
  for (int g = 0; g < gauss_; ++g) {
    const size_t gi = static_cast<size_t>(g);
    BeamShape(n_, xi_[gi], shape_[gi].data(), shape_xi_[gi].data());
  }
  // Reference strains: those of the initial configuration, so that it is stress-free.
  for (BeamElement& e : elements_) {
    const Local ql = e.q_ref.head(kCoordinatesPerBody * n_);
    StrainGradient B(6, kCoordinatesPerBody * n_);
    for (int g = 0; g < gauss_; ++g) Strains(e, ql, g, &e.reference[static_cast<size_t>(g)], &B);
  }
}

void BeamForce::Strains(const BeamElement& e, const Local& ql, int g, Vector6d* eps, StrainGradient* B) const {
  const double* N = shape_[static_cast<size_t>(g)].data();
  double dN[3];
  const double to_s = 2.0 / e.length;  // dξ/ds
  Eigen::Vector3d rp = Eigen::Vector3d::Zero();
  Eigen::Vector3d d[3], dp[3];
  for (int a = 0; a < 3; ++a) d[a].setZero(), dp[a].setZero();
  for (int I = 0; I < n_; ++I) {
    dN[I] = to_s * shape_xi_[static_cast<size_t>(g)][static_cast<size_t>(I)];
    rp += dN[I] * ql.segment<3>(Slot(I, 0));
    for (int a = 0; a < 3; ++a) {
      d[a] += N[I] * ql.segment<3>(Slot(I, a + 1));
      dp[a] += dN[I] * ql.segment<3>(Slot(I, a + 1));
    }
  }
  // Γ_1 = ½ r′·r′: the reference line's own stretch (its Green strain once Γ⁰_1 = ½ r′₀·r′₀ is
  // taken off). Measured along d_1 instead (d_1 · r′), a stretch of the reference line hides
  // where the interpolated d_1 is shorter than 1, between nodes whose sections turn: under a
  // spinning blade's tension that is a mode of negative stiffness (beam.h).
  (*eps)(0) = 0.5 * rp.dot(rp);
  // Γ_a = d_a · r′ (shears).
  for (int a = 1; a < 3; ++a) (*eps)(a) = d[a].dot(rp);
  // κ = ½ (d_b · d_c′ − d_c · d_b′) for (b, c) = (3, 2), (1, 3), (2, 1): torsion, flap, lag.
  static constexpr int kB[3] = {2, 0, 1}, kC[3] = {1, 2, 0};
  for (int k = 0; k < 3; ++k) (*eps)(3 + k) = 0.5 * (d[kB[k]].dot(dp[kC[k]]) - d[kC[k]].dot(dp[kB[k]]));
  B->setZero();
  for (int I = 0; I < n_; ++I) {
    B->block<1, 3>(0, Slot(I, 0)) = dN[I] * rp.transpose();
    for (int a = 1; a < 3; ++a) {
      B->block<1, 3>(a, Slot(I, 0)) = dN[I] * d[a].transpose();
      B->block<1, 3>(a, Slot(I, a + 1)) += N[I] * rp.transpose();
    }
    for (int k = 0; k < 3; ++k) {
      const int b = kB[k], c = kC[k];
      B->block<1, 3>(3 + k, Slot(I, b + 1)) += 0.5 * (N[I] * dp[c] - dN[I] * d[c]).transpose();
      B->block<1, 3>(3 + k, Slot(I, c + 1)) += 0.5 * (dN[I] * d[b] - N[I] * dp[b]).transpose();
    }
  }
}

void BeamForce::Gather(const BeamElement& e, const Eigen::VectorXd& q, Local* ql) const {
  ql->resize(kCoordinatesPerBody * n_);
  for (int I = 0; I < n_; ++I) {
    ql->segment<kCoordinatesPerBody>(kCoordinatesPerBody * I) =
        q.segment<kCoordinatesPerBody>(kCoordinatesPerBody * e.node[static_cast<size_t>(I)]);
  }
}

void BeamForce::Element(const BeamElement& e, const Local& ql, const Local& vl, Local* f, LocalMatrix* K,
                        LocalMatrix* C, double* energy) const {
  const int nl = kCoordinatesPerBody * n_;
  StrainGradient B(6, nl), Bv(6, nl);
  Vector6d eps, rate;
  for (int g = 0; g < gauss_; ++g) {
    const size_t gi = static_cast<size_t>(g);
    const double wJ = w_[gi] * 0.5 * e.length;
    Strains(e, ql, g, &eps, &B);
    eps -= e.reference[gi];
    const Matrix6d& D = e.stiffness[gi];
    Vector6d sigma = D * eps;
    if (energy != nullptr) *energy += 0.5 * wJ * eps.dot(sigma);
    const bool damped = retardation_ > 0.0;
    if (damped) {
      // Kelvin–Voigt: σ_v = β C ε̇ with ε̇ = B q̇; ∂ε̇/∂q = B(q̇) (B is linear in q).
      rate.noalias() = B * vl;
      sigma.noalias() += retardation_ * (D * rate);
    }
    if (f != nullptr) f->noalias() -= wJ * (B.transpose() * sigma);
    if (K == nullptr) continue;
    // Material part Bᵀ C B (and, damped, β Bᵀ C B(q̇) on K, β Bᵀ C B on C).
    const Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::RowMajor, 6, kMaxLocal> DB = D * B;
    K->noalias() += wJ * (B.transpose() * DB);
    if (damped) {
      Vector6d unused;
      Strains(e, vl, g, &unused, &Bv);
      K->noalias() += (wJ * retardation_) * (B.transpose() * (D * Bv));
      if (C != nullptr) C->noalias() += (wJ * retardation_) * (B.transpose() * DB);
    }
    // Geometric part Σ_k σ_k H_k (constant Hessians, scalar on slots ⊗ I3): with P_IJ = N_I N_J′,
    // Γ_1 = ½ Σ N_I′ N_J′ x_I · x_J, Γ_a = Σ P_IJ d_aI · x_J (a = 2, 3) and
    // κ = Σ ½(P_IJ − P_JI) d_bI · d_cJ.
    const double* N = shape_[gi].data();
    double dN[3];
    for (int I = 0; I < n_; ++I) dN[I] = shape_xi_[gi][static_cast<size_t>(I)] * 2.0 / e.length;
    static constexpr int kB[3] = {2, 0, 1}, kC[3] = {1, 2, 0};
    auto add = [&](int row, int col, double v) {
      for (int k = 0; k < 3; ++k) (*K)(row + k, col + k) += v;
    };
    for (int I = 0; I < n_; ++I) {
      for (int J = 0; J < n_; ++J) {
        const double P = wJ * N[I] * dN[J], A = 0.5 * wJ * (N[I] * dN[J] - N[J] * dN[I]);
        add(Slot(I, 0), Slot(J, 0), sigma(0) * wJ * dN[I] * dN[J]);  // Γ_1 = ½ Σ N_I′ N_J′ x_I · x_J
        for (int a = 1; a < 3; ++a) {
          add(Slot(I, a + 1), Slot(J, 0), sigma(a) * P);
          add(Slot(J, 0), Slot(I, a + 1), sigma(a) * P);
        }
        for (int k = 0; k < 3; ++k) {
          add(Slot(I, kB[k] + 1), Slot(J, kC[k] + 1), sigma(3 + k) * A);
          add(Slot(J, kC[k] + 1), Slot(I, kB[k] + 1), sigma(3 + k) * A);
        }
      }
    }
  }
}

void BeamForce::AddForce(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double, const SystemData&,
                         Eigen::Ref<Eigen::VectorXd> f) const {
  Local ql, vl, fl;
  for (const BeamElement& e : elements_) {
    Gather(e, q, &ql);
    if (retardation_ > 0.0) Gather(e, qdot, &vl);
    fl.setZero(ql.size());
    Element(e, ql, vl, &fl, nullptr, nullptr, nullptr);
    for (int I = 0; I < n_; ++I) {
      f.segment<kCoordinatesPerBody>(kCoordinatesPerBody * e.node[static_cast<size_t>(I)]) +=
          fl.segment<kCoordinatesPerBody>(kCoordinatesPerBody * I);
    }
  }
}

void BeamForce::AddTangent(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double, const SystemData&,
                           double stiffness_scale, double damping_scale, SparseSink* sink) const {
  Local ql, vl;
  LocalMatrix K, C;
  const int nl = kCoordinatesPerBody * n_;
  for (const BeamElement& e : elements_) {
    Gather(e, q, &ql);
    if (retardation_ > 0.0) Gather(e, qdot, &vl);
    K.setZero(nl, nl);
    C.setZero(nl, nl);
    Element(e, ql, vl, nullptr, &K, &C, nullptr);
    K *= stiffness_scale;
    if (retardation_ > 0.0) K += damping_scale * C;
    // In 3×3 blocks (slots x, d1, d2, d3 of each node): one search per column and block.
    for (int J = 0; J < n_; ++J) {
      const int cj = kCoordinatesPerBody * e.node[static_cast<size_t>(J)];
      for (int I = 0; I < n_; ++I) {
        const int ri = kCoordinatesPerBody * e.node[static_cast<size_t>(I)];
        for (int sc = 0; sc < kCoordinatesPerBody; sc += 3) {
          for (int sr = 0; sr < kCoordinatesPerBody; sr += 3) {
            sink->AddBlock3(ri + sr, cj + sc,
                            K.block<3, 3>(kCoordinatesPerBody * I + sr, kCoordinatesPerBody * J + sc));
          }
        }
      }
    }
  }
}

void BeamForce::Pattern(SparseSink* sink) const {
  for (const BeamElement& e : elements_) {
    for (int I = 0; I < n_; ++I) {
      for (int J = 0; J < n_; ++J) {
        const int ri = kCoordinatesPerBody * e.node[static_cast<size_t>(I)];
        const int cj = kCoordinatesPerBody * e.node[static_cast<size_t>(J)];
        for (int r = 0; r < kCoordinatesPerBody; ++r) {
          for (int c = 0; c < kCoordinatesPerBody; ++c) sink->Add(ri + r, cj + c, 0.0);
        }
      }
    }
  }
}

double BeamForce::PotentialEnergy(const Eigen::VectorXd& q) const {
  double energy = 0.0;
  Local ql, vl;
  for (const BeamElement& e : elements_) {
    Gather(e, q, &ql);
    vl.setZero(ql.size());  // the energy is the elastic one; the rate is not needed
    Element(e, ql, vl, nullptr, nullptr, nullptr, &energy);
  }
  return energy;
}

Vector6d BeamForce::SectionForces(const Eigen::VectorXd& q, double s) const {
  // The element holding s (the last one beyond the tip, the first before the root).
  size_t k = 0;
  while (k + 1 < elements_.size() && s > elements_[k].s0 + elements_[k].length) ++k;
  const BeamElement& e = elements_[k];
  const double xi = std::clamp(2.0 * (s - e.s0) / e.length - 1.0, -1.0, 1.0);
  Local ql;
  Gather(e, q, &ql);
  // Recovered from the Gauss points, where reduced integration samples the strains (elsewhere
  // the interpolated shear strain of a nearly shear-rigid section is noise times GA): constant
  // over a 2-node element, linear through the two points of a 3-node one.
  StrainGradient B(6, kCoordinatesPerBody * n_);
  std::array<Vector6d, 2> sigma;
  for (int g = 0; g < gauss_; ++g) {
    const size_t gi = static_cast<size_t>(g);
    Vector6d eps;
    Strains(e, ql, g, &eps, &B);
    sigma[gi] = e.stiffness[gi] * (eps - e.reference[gi]);
  }
  if (gauss_ == 1) return sigma[0];
  const double t = (xi - xi_[0]) / (xi_[1] - xi_[0]);
  return sigma[0] + t * (sigma[1] - sigma[0]);
}

Eigen::MatrixXd BeamElementMass(int n, double s0, double length, const BeamTable& table, double rotary_floor) {
  // Slot-space (x, d1, d2, d3 per node) mass: ∫ N_I N_J [m, m c_a, J_ab] ds, integrated exactly for
  // data linear between stations (3-point Gauss on each piece between the table's breaks:
  // N_I N_J is at most quartic, the data linear).
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(4 * n, 4 * n);
  std::vector<double> cuts{s0};
  for (double b : table.BreaksWithin(s0, s0 + length)) cuts.push_back(b);
  cuts.push_back(s0 + length);
  const double g[3] = {-std::sqrt(0.6), 0.0, std::sqrt(0.6)}, w[3] = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};
  for (size_t p = 0; p + 1 < cuts.size(); ++p) {
    const double a = cuts[p], b = cuts[p + 1];
    for (int k = 0; k < 3; ++k) {
      const double s = 0.5 * (a + b) + 0.5 * (b - a) * g[k];
      const double ds = 0.5 * (b - a) * w[k];
      // The piece lies inside one interval of the table: evaluate on its own side of a step.
      const BeamSection sec = table.At(s);
      const Eigen::Matrix2d J = SectionSecondMoments(sec);
      Eigen::Matrix4d local = Eigen::Matrix4d::Zero();  // over (x, d1, d2, d3)
      local(0, 0) = sec.mass;
      local(0, 2) = local(2, 0) = sec.mass * sec.cg2;
      local(0, 3) = local(3, 0) = sec.mass * sec.cg3;
      local.block<2, 2>(2, 2) = J;
      // Rotary floor (beam_model.h), f = rotary_floor. A rotation about d2 or d3 (bending) moves
      // d1 and d3 or d1 and d2: 2 f m on d1 gives them J33 + 2 f m and J22 + 2 f m, as the old
      // floor of f m on each director did. A rotation about d1 (torsion) moves d2 and d3 only:
      // the data's polar moment J22 + J33, raised to 2 f m only where the data give less (the
      // Puma's root, 0.28–0.604 m, has none); a floor of 2 f m everywhere added +23 % to the
      // Puma's torsional inertia.
      local(1, 1) += 2.0 * rotary_floor * sec.mass;
      const double deficit = std::max(0.0, 2.0 * rotary_floor * sec.mass - J.trace());
      local(2, 2) += 0.5 * deficit;
      local(3, 3) += 0.5 * deficit;
      double N[3], dN[3];
      BeamShape(n, 2.0 * (s - s0) / length - 1.0, N, dN);
      for (int I = 0; I < n; ++I) {
        for (int J2 = 0; J2 < n; ++J2) M.block<4, 4>(4 * I, 4 * J2) += (ds * N[I] * N[J2]) * local;
      }
    }
  }
  return M;
}

}  // namespace cosim::smooth
