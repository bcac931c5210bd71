#include "smooth_solver/constraints/bilinear_constraints.h"

#include <algorithm>
#include <cmath>

namespace cosim::smooth {

Eigen::Vector3d LinearVector::Value(const Eigen::Ref<const Eigen::VectorXd>& q) const {
  Eigen::Vector3d v = constant;
  for (const Term& t : terms) v += t.coefficient * q.segment<3>(t.offset);
  return v;
}

Eigen::Vector3d LinearVector::Rate(const Eigen::Ref<const Eigen::VectorXd>& qdot) const {
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  for (const Term& t : terms) v += t.coefficient * qdot.segment<3>(t.offset);
  return v;
}

LinearVector LinearVector::Point(int body, const Eigen::Vector3d& s) {
  LinearVector v;
  if (body < 0) {
    v.constant = s;
    return v;
  }
  const int o = kCoordinatesPerBody * body;
  v.terms.push_back({o, 1.0});
  for (int k = 0; k < 3; ++k) {
    if (s(k) != 0.0) v.terms.push_back({o + 3 + 3 * k, s(k)});
  }
  return v;
}

LinearVector LinearVector::Direction(int body, const Eigen::Vector3d& a) {
  LinearVector v;
  if (body < 0) {
    v.constant = a;
    return v;
  }
  const int o = kCoordinatesPerBody * body;
  for (int k = 0; k < 3; ++k) {
    if (a(k) != 0.0) v.terms.push_back({o + 3 + 3 * k, a(k)});
  }
  return v;
}

LinearVector LinearVector::Constant(const Eigen::Vector3d& c) {
  LinearVector v;
  v.constant = c;
  return v;
}

LinearVector LinearVector::operator-(const LinearVector& other) const {
  LinearVector v = *this;
  v.constant -= other.constant;
  for (Term t : other.terms) {
    t.coefficient = -t.coefficient;
    v.terms.push_back(t);
  }
  return v;
}

double ConstraintSet::Weight(const ImposedValues& imposed, const DriveWeight& w, double t, int derivative) const {
  if (w.kind == DriveWeight::Kind::kOne) return derivative == 0 ? w.scale : 0.0;
  const Drive& d = drives[static_cast<size_t>(w.drive)];
  const double th = d.Value(imposed, t), th_dot = d.Rate(imposed, t), th_ddot = d.Acceleration(imposed, t);
  const double s = std::sin(th), c = std::cos(th);
  switch (w.kind) {
    case DriveWeight::Kind::kSin:
      return w.scale * (derivative == 0 ? s : derivative == 1 ? c * th_dot : -s * th_dot * th_dot + c * th_ddot);
    case DriveWeight::Kind::kCos:
      return w.scale * (derivative == 0 ? c : derivative == 1 ? -s * th_dot : -c * th_dot * th_dot - s * th_ddot);
    case DriveWeight::Kind::kValue:
      return w.scale * (derivative == 0 ? th : derivative == 1 ? th_dot : th_ddot);
    case DriveWeight::Kind::kOne:
      break;
  }
  return 0.0;
}

void ConstraintSet::Evaluate(const ImposedValues& imposed, const Eigen::Ref<const Eigen::VectorXd>& q, double t,
                             Eigen::Ref<Eigen::VectorXd> phi) const {
  for (size_t i = 0; i < constraints.size(); ++i) {
    if (!Active(i, t)) {
      phi(static_cast<Eigen::Index>(i)) = 0.0;
      continue;
    }
    const ScalarConstraint& c = constraints[i];
    double value = c.constant * Weight(imposed, c.constant_weight, t, 0);
    for (const auto& term : c.terms) value += Weight(imposed, term.weight, t, 0) * term.a.Value(q).dot(term.b.Value(q));
    phi(static_cast<Eigen::Index>(i)) = value;
  }
}

namespace {

// Calls f(column, value) for every entry of row i of Φ_q: w (A_qᵀ B + B_qᵀ A).
template <typename F>
void ForEachJacobianEntry(const ScalarConstraint::Term& term, double w, const Eigen::Ref<const Eigen::VectorXd>& q,
                          F&& f) {
  const Eigen::Vector3d a = term.a.Value(q), b = term.b.Value(q);
  for (const auto& ta : term.a.terms) {
    for (int k = 0; k < 3; ++k) f(ta.offset + k, w * ta.coefficient * b(k));
  }
  for (const auto& tb : term.b.terms) {
    for (int k = 0; k < 3; ++k) f(tb.offset + k, w * tb.coefficient * a(k));
  }
}

}  // namespace

template <typename Fn>
void ConstraintSet::ForEachActiveEntry(const ImposedValues& imposed, const Eigen::Ref<const Eigen::VectorXd>& q,
                                       double t, double scale, Fn fn) const {
  for (size_t i = 0; i < constraints.size(); ++i) {
    if (!Active(i, t)) continue;
    const int constraint = static_cast<int>(i);
    for (const auto& term : constraints[i].terms) {
      ForEachJacobianEntry(term, scale * Weight(imposed, term.weight, t, 0), q,
                           [&](int column, double value) { fn(constraint, column, value); });
    }
  }
}

void ConstraintSet::Jacobian(const ImposedValues& imposed, const Eigen::Ref<const Eigen::VectorXd>& q, double t,
                             SparseSink* sink, int row_offset, double scale) const {
  ForEachActiveEntry(imposed, q, t, scale,
                     [&](int i, int column, double value) { sink->Add(row_offset + i, column, value); });
}

void ConstraintSet::JacobianTranspose(const ImposedValues& imposed, const Eigen::Ref<const Eigen::VectorXd>& q,
                                      double t, SparseSink* sink, int column_offset, double scale) const {
  ForEachActiveEntry(imposed, q, t, scale,
                     [&](int i, int row, double value) { sink->Add(row, column_offset + i, value); });
}

void ConstraintSet::AddJacobianTransposeTimes(const ImposedValues& imposed, const Eigen::Ref<const Eigen::VectorXd>& q,
                                              double t, const Eigen::Ref<const Eigen::VectorXd>& lambda,
                                              Eigen::Ref<Eigen::VectorXd> out) const {
  for (size_t i = 0; i < constraints.size(); ++i) {
    if (!Active(i, t)) continue;
    const double l = lambda(static_cast<Eigen::Index>(i));
    for (const auto& term : constraints[i].terms) {
      ForEachJacobianEntry(term, l * Weight(imposed, term.weight, t, 0), q,
                           [&](int column, double value) { out(column) += value; });
    }
  }
}

void ConstraintSet::JacobianTimes(const ImposedValues& imposed, const Eigen::Ref<const Eigen::VectorXd>& q, double t,
                                  const Eigen::Ref<const Eigen::VectorXd>& v, Eigen::Ref<Eigen::VectorXd> out,
                                  const std::vector<char>* rows) const {
  for (size_t i = 0; i < constraints.size(); ++i) {
    if (!Active(i, t) || (rows != nullptr && (*rows)[i] == 0)) {
      out(static_cast<Eigen::Index>(i)) = 0.0;
      continue;
    }
    double value = 0.0;
    for (const auto& term : constraints[i].terms) {
      // d/dε [A(q + εv)·B(q + εv)] = A_q v · B + A · B_q v.
      value += Weight(imposed, term.weight, t, 0) *
               (term.a.Rate(v).dot(term.b.Value(q)) + term.a.Value(q).dot(term.b.Rate(v)));
    }
    out(static_cast<Eigen::Index>(i)) = value;
  }
}

void ConstraintSet::HessianTimesLambda(const ImposedValues& imposed, double t,
                                       const Eigen::Ref<const Eigen::VectorXd>& lambda, SparseSink* sink,
                                       double scale) const {
  for (size_t i = 0; i < constraints.size(); ++i) {
    if (!Active(i, t)) continue;
    const double l = scale * lambda(static_cast<Eigen::Index>(i));
    if (l == 0.0) continue;
    for (const auto& term : constraints[i].terms) {
      const double w = l * Weight(imposed, term.weight, t, 0);
      // ∂²(A·B)/∂q² = A_qᵀ B_q + B_qᵀ A_q: identity blocks between the two vectors' terms.
      for (const auto& ta : term.a.terms) {
        for (const auto& tb : term.b.terms) {
          const double value = w * ta.coefficient * tb.coefficient;
          for (int k = 0; k < 3; ++k) {
            sink->Add(ta.offset + k, tb.offset + k, value);
            sink->Add(tb.offset + k, ta.offset + k, value);
          }
        }
      }
    }
  }
}

void ConstraintSet::AddReleasedDiagonal(double t, SparseSink* sink, int offset) const {
  for (size_t i = 0; i < constraints.size(); ++i) {
    if (!Active(i, t)) sink->Add(offset + static_cast<int>(i), offset + static_cast<int>(i), 1.0);
  }
}

void ConstraintSet::AddComplianceDiagonal(SparseSink* sink, int offset, double scale) const {
  for (size_t i = 0; i < compliance.size(); ++i) {
    if (compliance[i] != 0.0)
      sink->Add(offset + static_cast<int>(i), offset + static_cast<int>(i), -scale * compliance[i]);
  }
}

double ConstraintSet::NextRelease(double t0, double t1) const {
  double next = std::numeric_limits<double>::infinity();
  for (const auto& c : constraints) {
    if (c.release_time > t0 && c.release_time <= t1) next = std::min(next, c.release_time);
  }
  return next;
}

double ConstraintSet::ReleaseWithin(double t0, double t1) const {
  double first = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < constraints.size(); ++i) {
    if (Active(i, t0) && !Active(i, t1)) first = std::min(first, constraints[i].release_time);
  }
  return first;
}

void ConstraintSet::HessianPattern(SparseSink* sink) const {
  for (const auto& c : constraints) {
    for (const auto& term : c.terms) {
      for (const auto& ta : term.a.terms) {
        for (const auto& tb : term.b.terms) {
          for (int k = 0; k < 3; ++k) {
            sink->Add(ta.offset + k, tb.offset + k, 0.0);
            sink->Add(tb.offset + k, ta.offset + k, 0.0);
          }
        }
      }
    }
  }
}

void ConstraintSet::AccelerationBias(const ImposedValues& imposed, const Eigen::Ref<const Eigen::VectorXd>& q,
                                     const Eigen::Ref<const Eigen::VectorXd>& qdot, double t,
                                     Eigen::Ref<Eigen::VectorXd> xi) const {
  // d²/dt² [w A·B] = ẅ A·B + 2ẇ (Ȧ·B + A·Ḃ) + w (Ä·B + 2 Ȧ·Ḃ + A·B̈); the Ä, B̈ part is Φ_q q̈.
  for (size_t i = 0; i < constraints.size(); ++i) {
    if (!Active(i, t)) {
      xi(static_cast<Eigen::Index>(i)) = 0.0;
      continue;
    }
    const ScalarConstraint& c = constraints[i];
    double value = c.constant * Weight(imposed, c.constant_weight, t, 2);
    for (const auto& term : c.terms) {
      const Eigen::Vector3d a = term.a.Value(q), b = term.b.Value(q);
      const Eigen::Vector3d a_dot = term.a.Rate(qdot), b_dot = term.b.Rate(qdot);
      value += Weight(imposed, term.weight, t, 2) * a.dot(b) +
               2.0 * Weight(imposed, term.weight, t, 1) * (a_dot.dot(b) + a.dot(b_dot)) +
               2.0 * Weight(imposed, term.weight, t, 0) * a_dot.dot(b_dot);
    }
    xi(static_cast<Eigen::Index>(i)) = value;
  }
}

void ConstraintSet::VelocityConstraintJacobian(const ImposedValues& imposed, const Eigen::Ref<const Eigen::VectorXd>& q,
                                               const Eigen::Ref<const Eigen::VectorXd>& v, double t, SparseSink* sink,
                                               int row_offset, double scale, const std::vector<char>* rows) const {
  // Φ_q v = Σ w (A_q v · B + A · B_q v):  ∂/∂q = w ((B_q v)ᵀ A_q + (A_q v)ᵀ B_q);
  // Φ_t = Σ ẇ A·B:  ∂/∂q = ẇ (Bᵀ A_q + Aᵀ B_q).
  for (size_t i = 0; i < constraints.size(); ++i) {
    if (!Active(i, t) || (rows != nullptr && (*rows)[i] == 0)) continue;
    const int row = row_offset + static_cast<int>(i);
    for (const auto& term : constraints[i].terms) {
      const double w = Weight(imposed, term.weight, t, 0), w_dot = Weight(imposed, term.weight, t, 1);
      const Eigen::Vector3d a = term.a.Value(q), b = term.b.Value(q);
      const Eigen::Vector3d a_rate = term.a.Rate(v), b_rate = term.b.Rate(v);
      const Eigen::Vector3d along_a = scale * (w * b_rate + w_dot * b), along_b = scale * (w * a_rate + w_dot * a);
      for (const auto& ta : term.a.terms) {
        for (int k = 0; k < 3; ++k) sink->Add(row, ta.offset + k, ta.coefficient * along_a(k));
      }
      for (const auto& tb : term.b.terms) {
        for (int k = 0; k < 3; ++k) sink->Add(row, tb.offset + k, tb.coefficient * along_b(k));
      }
    }
  }
}

void ConstraintSet::TimeDerivative(const ImposedValues& imposed, const Eigen::Ref<const Eigen::VectorXd>& q, double t,
                                   Eigen::Ref<Eigen::VectorXd> phi_t, const std::vector<char>* rows) const {
  for (size_t i = 0; i < constraints.size(); ++i) {
    if (!Active(i, t) || (rows != nullptr && (*rows)[i] == 0)) {
      phi_t(static_cast<Eigen::Index>(i)) = 0.0;
      continue;
    }
    const ScalarConstraint& c = constraints[i];
    double value = c.constant * Weight(imposed, c.constant_weight, t, 1);
    for (const auto& term : c.terms) value += Weight(imposed, term.weight, t, 1) * term.a.Value(q).dot(term.b.Value(q));
    phi_t(static_cast<Eigen::Index>(i)) = value;
  }
}

}  // namespace cosim::smooth
