#include "smooth_solver/forces/force_elements.h"

#include <algorithm>
#include <cmath>

#include "interface/base/errors.h"

namespace cosim::smooth {

namespace {

Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d s;
  s << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return s;
}

}  // namespace

// ---------------------------------------------------------------------------------------
AppliedLoad::AppliedLoad(int body, const Eigen::Vector3d& point, std::array<interface::TimeFunction, 3> force,
                         std::array<interface::TimeFunction, 3> torque, bool has_torque)
    : offset_(kCoordinatesPerBody * body),
      point_(point),
      force_(std::move(force)),
      torque_(std::move(torque)),
      has_torque_(has_torque) {}

Eigen::Vector3d AppliedLoad::Value(const std::array<interface::TimeFunction, 3>& f, double t) const {
  return Eigen::Vector3d(f[0].Value(t), f[1].Value(t), f[2].Value(t));
}

void AppliedLoad::AddForce(const Eigen::VectorXd& q, const Eigen::VectorXd&, double t, const SystemData&,
                           Eigen::Ref<Eigen::VectorXd> f) const {
  const Eigen::Vector3d F = Value(force_, t);
  f.segment<3>(offset_) += F;
  const Eigen::Vector3d T = has_torque_ ? Value(torque_, t) : Eigen::Vector3d::Zero();
  for (int k = 0; k < 3; ++k) {
    const int o = offset_ + 3 + 3 * k;
    f.segment<3>(o) += point_(k) * F + 0.5 * T.cross(Eigen::Vector3d(q.segment<3>(o)));
  }
}

void AppliedLoad::AddTangent(const Eigen::VectorXd&, const Eigen::VectorXd&, double t, const SystemData&,
                             double stiffness_scale, double, SparseSink* sink) const {
  if (!has_torque_) return;
  // f_{u_k} = ½ T × u_k = ½ [T]× u_k:  K = −∂f/∂q = −½ [T]× on each axis block.
  const Eigen::Matrix3d block = -0.5 * stiffness_scale * Skew(Value(torque_, t));
  for (int k = 0; k < 3; ++k) {
    const int o = offset_ + 3 + 3 * k;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) {
        if (r != c) sink->Add(o + r, o + c, block(r, c));
      }
    }
  }
}

void AppliedLoad::Pattern(SparseSink* sink) const {
  if (!has_torque_) return;
  for (int k = 0; k < 3; ++k) {
    const int o = offset_ + 3 + 3 * k;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) sink->Add(o + r, o + c, 0.0);
    }
  }
}

// ---------------------------------------------------------------------------------------
PointSpring::PointSpring(LinearVector p1, LinearVector p2, double stiffness, double damping, double rest_length)
    : d_(p2 - p1), k_(stiffness), c_(damping), rest_(rest_length) {}

void PointSpring::AddForce(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double, const SystemData&,
                           Eigen::Ref<Eigen::VectorXd> f) const {
  const Eigen::Vector3d d = d_.Value(q), d_dot = d_.Rate(qdot);
  const double L = d.norm();
  if (!(L > 0.0)) return;  // coincident points: no direction, no force
  const Eigen::Vector3d n = d / L;
  const Eigen::Vector3d F = (k_ * (L - rest_) + c_ * n.dot(d_dot)) * n;
  // Virtual work −F·δd: f = −D_qᵀ F.
  for (const auto& t : d_.terms) f.segment<3>(t.offset) -= t.coefficient * F;
}

void PointSpring::AddTangent(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double, const SystemData&,
                             double stiffness_scale, double damping_scale, SparseSink* sink) const {
  const Eigen::Vector3d d = d_.Value(q), d_dot = d_.Rate(qdot);
  const double L = d.norm();
  if (!(L > 0.0)) return;
  const Eigen::Vector3d n = d / L;
  const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - n * n.transpose();  // ∂n/∂d = P/L
  const double phi = k_ * (L - rest_) + c_ * n.dot(d_dot);
  // F = φ n:  ∂F/∂d = n (k nᵀ + c ḋᵀ P / L) + φ P / L,  ∂F/∂ḋ = c n nᵀ.
  const Eigen::Matrix3d dF_dd = n * (k_ * n.transpose() + c_ * d_dot.transpose() * P / L) + phi * P / L;
  const Eigen::Matrix3d block = stiffness_scale * dF_dd + damping_scale * c_ * n * n.transpose();
  // K = −∂f/∂q = D_qᵀ ∂F/∂d D_q (and C likewise).
  for (const auto& ta : d_.terms) {
    for (const auto& tb : d_.terms) {
      const double w = ta.coefficient * tb.coefficient;
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) sink->Add(ta.offset + r, tb.offset + c, w * block(r, c));
      }
    }
  }
}

void PointSpring::Pattern(SparseSink* sink) const {
  for (const auto& ta : d_.terms) {
    for (const auto& tb : d_.terms) {
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) sink->Add(ta.offset + r, tb.offset + c, 0.0);
      }
    }
  }
}

double PointSpring::PotentialEnergy(const Eigen::VectorXd& q) const {
  const double stretch = d_.Value(q).norm() - rest_;
  return 0.5 * k_ * stretch * stretch;
}

// ---------------------------------------------------------------------------------------
CoordinateSpring::CoordinateSpring(LinearVector b1, LinearVector c1, LinearVector b2, double stiffness, double damping,
                                   double rest)
    : revolute_(true),
      a_(std::move(b1)),
      b_(std::move(c1)),
      c_(std::move(b2)),
      k_(stiffness),
      damping_(damping),
      rest_(rest) {
  Collect();
}

CoordinateSpring::CoordinateSpring(LinearVector separation, LinearVector axis, double stiffness, double damping,
                                   double rest)
    : revolute_(false), a_(std::move(separation)), b_(std::move(axis)), k_(stiffness), damping_(damping), rest_(rest) {
  Collect();
}

void CoordinateSpring::Collect() {
  for (const LinearVector* v : {&a_, &b_, &c_}) {
    for (const auto& t : v->terms) {
      for (int k = 0; k < 3; ++k) coordinates_.push_back(t.offset + k);
    }
  }
  std::sort(coordinates_.begin(), coordinates_.end());
  coordinates_.erase(std::unique(coordinates_.begin(), coordinates_.end()), coordinates_.end());
  COSIM_ASSERT(static_cast<int>(coordinates_.size()) <= kMaxLocal,
               "a coordinate spring spans more than two bodies' coordinates");
}

namespace {

// A·B with its gradient and (constant) Hessian over the local coordinates `index`.
struct Bilinear {
  double value = 0.0;
  CoordinateSpring::LocalVector gradient;
  CoordinateSpring::LocalMatrix hessian;
};

Bilinear LocalDot(const LinearVector& A, const LinearVector& B, const Eigen::VectorXd& q, const std::vector<int>& index,
                  bool hessian) {
  const int n = static_cast<int>(index.size());
  auto local = [&](int global) {
    return static_cast<int>(std::lower_bound(index.begin(), index.end(), global) - index.begin());
  };
  Bilinear r;
  r.gradient.setZero(n);
  const Eigen::Vector3d a = A.Value(q), b = B.Value(q);
  r.value = a.dot(b);
  for (const auto& ta : A.terms) {
    for (int k = 0; k < 3; ++k) r.gradient(local(ta.offset + k)) += ta.coefficient * b(k);
  }
  for (const auto& tb : B.terms) {
    for (int k = 0; k < 3; ++k) r.gradient(local(tb.offset + k)) += tb.coefficient * a(k);
  }
  if (!hessian) return r;
  r.hessian.setZero(n, n);
  for (const auto& ta : A.terms) {
    for (const auto& tb : B.terms) {
      for (int k = 0; k < 3; ++k) {
        const int i = local(ta.offset + k), j = local(tb.offset + k);
        r.hessian(i, j) += ta.coefficient * tb.coefficient;
        r.hessian(j, i) += ta.coefficient * tb.coefficient;
      }
    }
  }
  return r;
}

}  // namespace

CoordinateSpring::Local CoordinateSpring::Evaluate(const Eigen::VectorXd& q, bool hessian) const {
  Local out;
  if (!revolute_) {
    const Bilinear s = LocalDot(a_, b_, q, coordinates_, hessian);
    out.value = s.value;
    out.gradient = s.gradient;
    out.hessian = s.hessian;
    return out;
  }
  // θ = atan2(y, x), x = b2·b1, y = b2·c1:
  //   ∇θ = (x∇y − y∇x)/r²,
  //   ∇²θ = (x∇²y − y∇²x + ∇y∇xᵀ − ∇x∇yᵀ)/r² − 2 (x∇y − y∇x)(x∇x + y∇y)ᵀ/r⁴   (symmetric).
  const Bilinear x = LocalDot(c_, a_, q, coordinates_, hessian), y = LocalDot(c_, b_, q, coordinates_, hessian);
  const double r2 = x.value * x.value + y.value * y.value;
  const LocalVector u = x.value * y.gradient - y.value * x.gradient;
  out.value = std::atan2(y.value, x.value);
  out.gradient = u / r2;
  if (!hessian) return out;
  const LocalVector w = x.value * x.gradient + y.value * y.gradient;
  out.hessian = (x.value * y.hessian - y.value * x.hessian + y.gradient * x.gradient.transpose() -
                 x.gradient * y.gradient.transpose()) /
                    r2 -
                2.0 * u * w.transpose() / (r2 * r2);
  const LocalMatrix symmetric = 0.5 * (out.hessian + out.hessian.transpose());
  out.hessian = symmetric;
  return out;
}

void CoordinateSpring::AddForce(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double, const SystemData&,
                                Eigen::Ref<Eigen::VectorXd> f) const {
  const Local l = Evaluate(q, /*hessian=*/false);
  double rate = 0.0;
  for (size_t i = 0; i < coordinates_.size(); ++i)
    rate += l.gradient(static_cast<Eigen::Index>(i)) * qdot(coordinates_[i]);
  const double tau = k_ * (l.value - rest_) + damping_ * rate;
  for (size_t i = 0; i < coordinates_.size(); ++i) f(coordinates_[i]) -= tau * l.gradient(static_cast<Eigen::Index>(i));
}

void CoordinateSpring::AddTangent(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double, const SystemData&,
                                  double stiffness_scale, double damping_scale, SparseSink* sink) const {
  const Local l = Evaluate(q);
  const int n = static_cast<int>(coordinates_.size());
  LocalVector v(n);
  for (int i = 0; i < n; ++i) v(i) = qdot(coordinates_[static_cast<size_t>(i)]);
  const double rate = l.gradient.dot(v);
  const double tau = k_ * (l.value - rest_) + damping_ * rate;
  // f = −τ ∇θ:  K = k ∇θ∇θᵀ + c ∇θ (∇²θ q̇)ᵀ + τ ∇²θ,  C = c ∇θ∇θᵀ.
  const LocalVector hv = l.hessian * v;
  const LocalMatrix K =
      k_ * l.gradient * l.gradient.transpose() + damping_ * l.gradient * hv.transpose() + tau * l.hessian;
  const LocalMatrix C = damping_ * l.gradient * l.gradient.transpose();
  const LocalMatrix T = stiffness_scale * K + damping_scale * C;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j)
      sink->Add(coordinates_[static_cast<size_t>(i)], coordinates_[static_cast<size_t>(j)], T(i, j));
  }
}

void CoordinateSpring::Pattern(SparseSink* sink) const {
  for (int i : coordinates_) {
    for (int j : coordinates_) sink->Add(i, j, 0.0);
  }
}

double CoordinateSpring::PotentialEnergy(const Eigen::VectorXd& q) const {
  const double s = Evaluate(q, /*hessian=*/false).value - rest_;
  return 0.5 * k_ * s * s;
}

void UnilateralContact::AcceptStep(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double /*t*/,
                                   SystemData* data) const {
  const State s = Measure(q, qdot);
  if (s.delta <= 0.0) data->impact_speed[slot_] = std::max(s.rate, law_.speed_threshold);  // the approach speed so far
}

double UnilateralContact::TimeToContact(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot) const {
  const State s = Measure(q, qdot);
  if (s.delta >= 0.0 || s.rate <= 0.0) return std::numeric_limits<double>::infinity();  // in contact, or opening
  return -s.delta / s.rate;
}

UnilateralContact::State UnilateralContact::Measure(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot) const {
  State s;
  s.measure = measure_.Evaluate(q, /*hessian=*/false);
  double theta_dot = 0.0;
  const auto& index = measure_.coordinates();
  for (size_t i = 0; i < index.size(); ++i)
    theta_dot += s.measure.gradient(static_cast<Eigen::Index>(i)) * qdot(index[i]);
  s.delta = side_ * (threshold_ - s.measure.value);
  s.rate = -side_ * theta_dot;
  return s;
}

UnilateralContact::State UnilateralContact::Evaluate(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot,
                                                     const SystemData& data) const {
  State s = Measure(q, qdot);
  const interface::HuntCrossleyForce c =
      interface::EvaluateHuntCrossley(law_, data.impact_speed[slot_], s.delta, s.rate);
  s.f = c.f;
  s.df_ddelta = c.df_ddelta;
  s.df_drate = c.df_drate;
  return s;
}

double UnilateralContact::PotentialEnergy(const Eigen::VectorXd& q) const {
  const double delta = side_ * (threshold_ - measure_.Evaluate(q, /*hessian=*/false).value);
  if (!(delta > 0.0)) return 0.0;
  return law_.stiffness * std::pow(delta, law_.exponent + 1.0) / (law_.exponent + 1.0);
}

void UnilateralContact::AddForce(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double, const SystemData& data,
                                 Eigen::Ref<Eigen::VectorXd> f) const {
  const State c = Evaluate(q, qdot, data);
  if (c.f == 0.0) return;
  const auto& index = measure_.coordinates();
  // The force opposes penetration: its virtual work is −f δδ, so Q = −f ∇δ = side f ∇θ.
  for (size_t i = 0; i < index.size(); ++i) {
    f(index[i]) += side_ * c.f * c.measure.gradient(static_cast<Eigen::Index>(i));
  }
}

void UnilateralContact::AddTangent(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double,
                                   const SystemData& data, double stiffness_scale, double damping_scale,
                                   SparseSink* sink) const {
  const State c = Evaluate(q, qdot, data);
  if (c.f == 0.0) return;  // open: no tangent (and no Hessian to make)
  const CoordinateSpring::Local l = measure_.Evaluate(q, /*hessian=*/true);
  const auto& index = measure_.coordinates();
  const int n = static_cast<int>(index.size());
  using LocalVector = CoordinateSpring::LocalVector;
  using LocalMatrix = CoordinateSpring::LocalMatrix;
  LocalVector v(n);
  for (int i = 0; i < n; ++i) v(i) = qdot(index[static_cast<size_t>(i)]);
  // δ = side (θ0 − θ): ∇δ = −side ∇θ, ∇²δ = −side ∇²θ, δ̇ = ∇δ·q̇.
  const LocalVector g = -side_ * l.gradient;
  const LocalMatrix H = -side_ * l.hessian;
  // Q = −f ∇δ: −∂Q/∂q = ∇δ (f_δ ∇δ + f_δ̇ ∇²δ q̇)ᵀ + f ∇²δ =: K, −∂Q/∂q̇ = f_δ̇ ∇δ ∇δᵀ =: C.
  const LocalVector Hv = H * v;
  const LocalVector a = c.df_ddelta * g + c.df_drate * Hv;
  const LocalMatrix K = g * a.transpose() + c.f * H;
  const LocalMatrix C = c.df_drate * g * g.transpose();
  const LocalMatrix T = stiffness_scale * K + damping_scale * C;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) sink->Add(index[static_cast<size_t>(i)], index[static_cast<size_t>(j)], T(i, j));
  }
}

}  // namespace cosim::smooth
