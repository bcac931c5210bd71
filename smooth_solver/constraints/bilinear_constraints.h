#pragma once
// Holonomic constraints in natural (fully Cartesian) coordinates.
//
// Each rigid body b has 12 coordinates q = [x, u, v, w]: its centre of mass x and the
// three unit vectors of its body frame (design.md, "Smooth solver coordinates"). A material
// point s (body frame) is x + s_x u + s_y v + s_z w and a material direction a is
// a_x u + a_y v + a_z w: both LINEAR in q. Every constraint the solver uses is then a
// weighted sum of dot products of two such linear vectors,
//     φ(q, t) = Σ_j w_j(t) A_j(q)·B_j(q) + c(t),
// so that Φ_q, the Hessians (constant), Φ_t and Φ_tt follow exactly and cheaply.
#include <Eigen/Core>
#include <limits>
#include <string>
#include <vector>

#include "interface/scenario/time_function.h"

namespace cosim::smooth {

inline constexpr int kCoordinatesPerBody = 12;

// Rigid body `body`'s axes [u v w] (the columns of its rotation) from the coordinates q.
inline Eigen::Matrix3d BodyAxes(const Eigen::VectorXd& q, int body) {
  Eigen::Matrix3d axes;
  for (int k = 0; k < 3; ++k) axes.col(k) = q.segment<3>(kCoordinatesPerBody * body + 3 + 3 * k);
  return axes;
}

// Its angular velocity ω = ½ Σ_k e_k × ė_k from the axes' rates (rate = q̇), or its angular
// acceleration ω̇ = ½ Σ_k e_k × ë_k (rate = q̈): exact for orthonormal axes.
inline Eigen::Vector3d BodyAngularRate(const Eigen::VectorXd& q, const Eigen::VectorXd& rate, int body) {
  Eigen::Vector3d w = Eigen::Vector3d::Zero();
  const int o = kCoordinatesPerBody * body + 3;
  for (int k = 0; k < 3; ++k) w += 0.5 * q.segment<3>(o + 3 * k).cross(rate.segment<3>(o + 3 * k));
  return w;
}

// A 3-vector linear in q: Σ_k coefficient_k q[offset_k .. offset_k + 2] + constant.
struct LinearVector {
  struct Term {
    int offset = 0;  // first of the three coordinates
    double coefficient = 1.0;
  };
  std::vector<Term> terms;
  Eigen::Vector3d constant = Eigen::Vector3d::Zero();

  Eigen::Vector3d Value(const Eigen::Ref<const Eigen::VectorXd>& q) const;
  // d/dt of Value along q̇ (the constant part does not move).
  Eigen::Vector3d Rate(const Eigen::Ref<const Eigen::VectorXd>& qdot) const;

  // Material point `s` (body frame) of body `body` (-1: ground, a constant point `s`).
  static LinearVector Point(int body, const Eigen::Vector3d& s);
  // Material direction `a` (body frame) of body `body` (-1: ground, the constant `a`).
  static LinearVector Direction(int body, const Eigen::Vector3d& a);
  // A fixed global vector.
  static LinearVector Constant(const Eigen::Vector3d& c);
  LinearVector operator-(const LinearVector& other) const;
};

// Weight of a term or the constant as a function of time: 1, sin θ(t), cos θ(t) or θ(t)
// for a drive angle (or displacement) θ(t).
struct DriveWeight {
  enum class Kind { kOne, kSin, kCos, kValue };
  Kind kind = Kind::kOne;
  double scale = 1.0;
  int drive = -1;  // index into ConstraintSet::drives; -1 for kOne
};

struct ScalarConstraint {
  struct Term {
    LinearVector a, b;
    DriveWeight weight;
  };
  std::string name;  // e.g. "hinge.revolute_axis_1" or "arm.unit_u"
  std::vector<Term> terms;
  double constant = 0.0;        // c, constant part
  DriveWeight constant_weight;  // c(t) = constant × weight(t)
  // A locked joint's constraint holds up to this time [s] included, then no longer exists: its row
  // contributes nothing and its multiplier is zero (integrators put an identity row there).
  double release_time = std::numeric_limits<double>::infinity();
  // A lock whose value the initial-condition solver chooses (Joint.lock_at_closure): left out of
  // the loop closure, then `constant` is set so that the row holds the closed configuration.
  bool set_by_closure = false;
};

// A coordinate a coupling peer gives instead of a time function: its value, rate and
// acceleration at the end of the step under way, set by the coordinator between iterations
// (the contact node's position imposed on a material point, rotor-sailing paper Eq. (6)).
struct ImposedCoordinate {
  double value = 0.0, rate = 0.0, acceleration = 0.0;
};

// The coordinates the coupling peers impose now (SystemData::imposed): an input of every
// evaluation of the constraints, never stored in them.
using ImposedValues = std::vector<ImposedCoordinate>;

// A prescribed joint coordinate θ(t) (angle or displacement), with its derivatives; or, if
// `imposed` >= 0, the coordinate the coupling peer imposes now (imposed values, that index;
// t is then not used).
struct Drive {
  interface::TimeFunction function;
  bool is_rate = false;  // the function gives θ̇ (speed drives): θ = ∫ f
  int imposed = -1;
  double Value(const ImposedValues& now, double t) const {
    return imposed >= 0 ? now[static_cast<size_t>(imposed)].value : is_rate ? function.Integral(t) : function.Value(t);
  }
  double Rate(const ImposedValues& now, double t) const {
    return imposed >= 0 ? now[static_cast<size_t>(imposed)].rate : is_rate ? function.Value(t) : function.Derivative(t);
  }
  double Acceleration(const ImposedValues& now, double t) const {
    return imposed >= 0 ? now[static_cast<size_t>(imposed)].acceleration
           : is_rate    ? function.Derivative(t)
                        : function.SecondDerivative(t);
  }
};

// Triplet sink for sparse assembly: (row, column, value) added into a matrix whose pattern
// was fixed beforehand.
class SparseSink {
 public:
  virtual ~SparseSink() = default;
  virtual void Add(int row, int column, double value) = 0;
  // A dense 3×3 block at (row, column): sinks with a costly Add (a search per entry) find each
  // column's three rows at once.
  virtual void AddBlock3(int row, int column, const Eigen::Matrix3d& block) {
    for (int c = 0; c < 3; ++c) {
      for (int r = 0; r < 3; ++r) Add(row + r, column + c, block(r, c));
    }
  }
  // scale × a dense count × count matrix (column-major `values`) at rows and columns `index`
  // (an element matrix): sinks with a costly Add find each column's entries in one pass, with
  // workspaces of kMaxDense on the stack (larger ones go entry by entry).
  static constexpr int kMaxDense = 96;  // a hex27's 81 coordinates
  virtual void AddDense(const int* index, int count, const double* values, double scale) {
    for (int c = 0; c < count; ++c) {
      for (int r = 0; r < count; ++r) Add(index[r], index[c], scale * values[r + c * count]);
    }
  }
};

class ConstraintSet {
 public:
  std::vector<ScalarConstraint> constraints;
  std::vector<Drive> drives;
  // Tikhonov regularisation of row i, Φ_i − c_i λ_i = 0 (rotor-sailing paper, Eq. (7)); empty:
  // none. CGα and the initial position and velocity solves honour it; the initial accelerations
  // leave the regularised (coupling) rows out.
  std::vector<double> compliance;
  // First rows of the row triples e_k · d(q) = 0 (k = x, y, z: a joint's, clamp's or coupling
  // node's point coincidence along the global axes), whose three multipliers are the components
  // of one global vector: a Newton matrix carried along with a rotation R rotates them as it
  // rotates the coordinates (CgAlpha, "co-rotated reuse").
  std::vector<int> vector_triples;
  double Compliance(size_t i) const { return i < compliance.size() ? compliance[i] : 0.0; }
  // −scale · c_i on the diagonal (offset + i, offset + i) of every regularised row: the
  // ∂(Φ_i − c_i λ_i)/∂λ_i block of a saddle-point matrix whose multipliers are scaled by `scale`.
  void AddComplianceDiagonal(SparseSink* sink, int offset, double scale) const;

  int size() const { return static_cast<int>(constraints.size()); }
  bool Active(size_t i, double t) const { return t <= constraints[i].release_time; }
  // 1 on the diagonal (offset + i, offset + i) of every released row i, so that the
  // saddle-point matrix stays regular and the row's multiplier stays zero.
  void AddReleasedDiagonal(double t, SparseSink* sink, int offset) const;
  // The earliest release time in (t0, t1], or +∞.
  double NextRelease(double t0, double t1) const;
  // The earliest release time of a row active at t0 and released at t1, or +∞.
  double ReleaseWithin(double t0, double t1) const;

  // Every evaluation below reads the drives' values from the imposed values of now (those of
  // the coupling rows; an empty set for a system without).
  // Φ(q, t) into `phi` (size m).
  void Evaluate(const ImposedValues& imposed, const Eigen::Ref<const Eigen::VectorXd>& q, double t,
                Eigen::Ref<Eigen::VectorXd> phi) const;
  // Φ_q into `sink` at (row_offset + i, column), scaled by `scale`.
  void Jacobian(const ImposedValues& imposed, const Eigen::Ref<const Eigen::VectorXd>& q, double t, SparseSink* sink,
                int row_offset, double scale) const;
  // The same transposed: (column, row_offset + i).
  void JacobianTranspose(const ImposedValues& imposed, const Eigen::Ref<const Eigen::VectorXd>& q, double t,
                         SparseSink* sink, int column_offset, double scale) const;
  // Φ_qᵀ λ into `out` (size n, accumulated).
  void AddJacobianTransposeTimes(const ImposedValues& imposed, const Eigen::Ref<const Eigen::VectorXd>& q, double t,
                                 const Eigen::Ref<const Eigen::VectorXd>& lambda,
                                 Eigen::Ref<Eigen::VectorXd> out) const;
  // Φ_q v into `out` (size m). `rows` (optional): only the rows flagged non-zero, 0 elsewhere
  // (here and in VelocityConstraintJacobian and TimeDerivative).
  void JacobianTimes(const ImposedValues& imposed, const Eigen::Ref<const Eigen::VectorXd>& q, double t,
                     const Eigen::Ref<const Eigen::VectorXd>& v, Eigen::Ref<Eigen::VectorXd> out,
                     const std::vector<char>* rows = nullptr) const;
  // scale · Σ_i λ_i ∂²φ_i/∂q² into `sink` (constant Hessians of the bilinear terms).
  void HessianTimesLambda(const ImposedValues& imposed, double t, const Eigen::Ref<const Eigen::VectorXd>& lambda,
                          SparseSink* sink, double scale) const;
  // Every (row, column) HessianTimesLambda may touch, for the sparsity pattern.
  void HessianPattern(SparseSink* sink) const;
  // The acceleration right-hand side: Φ_q q̈ = −ξ, ξ = (Φ_q q̇)_q q̇ + 2 Φ_qt q̇ + Φ_tt.
  void AccelerationBias(const ImposedValues& imposed, const Eigen::Ref<const Eigen::VectorXd>& q,
                        const Eigen::Ref<const Eigen::VectorXd>& qdot, double t, Eigen::Ref<Eigen::VectorXd> xi) const;
  // ∂(Φ_q v + Φ_t)/∂q into `sink` at (row_offset + i, column): the derivative of the velocity
  // constraint with respect to the positions (index-2 formulations).
  void VelocityConstraintJacobian(const ImposedValues& imposed, const Eigen::Ref<const Eigen::VectorXd>& q,
                                  const Eigen::Ref<const Eigen::VectorXd>& v, double t, SparseSink* sink,
                                  int row_offset, double scale = 1.0, const std::vector<char>* rows = nullptr) const;
  // Φ_t (size m): the velocity constraint is Φ_q q̇ + Φ_t = 0.
  void TimeDerivative(const ImposedValues& imposed, const Eigen::Ref<const Eigen::VectorXd>& q, double t,
                      Eigen::Ref<Eigen::VectorXd> phi_t, const std::vector<char>* rows = nullptr) const;

 private:
  double Weight(const ImposedValues& imposed, const DriveWeight& w, double t, int derivative) const;
  // fn(i, column, value) for each entry of each active constraint i's row of scale · Φ_q(q)
  // (Jacobian and JacobianTranspose, which differ only in where they put it).
  template <typename Fn>
  void ForEachActiveEntry(const ImposedValues& imposed, const Eigen::Ref<const Eigen::VectorXd>& q, double t,
                          double scale, Fn fn) const;
};

}  // namespace cosim::smooth
