#pragma once
// Force elements of the smooth model in natural coordinates: applied loads, translational
// spring-dampers between body points, and spring-dampers on joint coordinates. Each gives
// its generalised force f(q, q̇, t) and the exact tangents K = −∂f/∂q, C = −∂f/∂q̇ that
// CGα's Newton matrix and IDA's Jacobian need (checked against finite differences in
// tests/smooth_solver/force_elements_test.cpp).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

#include "interface/contact/hunt_crossley.h"
#include "smooth_solver/constraints/bilinear_constraints.h"
#include "smooth_solver/data/system_data.h"

namespace cosim::smooth {

class ForceElement {
 public:
  virtual ~ForceElement() = default;
  // f += generalised force at (q, q̇, t).
  virtual void AddForce(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, const SystemData& data,
                        Eigen::Ref<Eigen::VectorXd> f) const = 0;
  // sink += stiffness_scale · K + damping_scale · C (entries in q-space).
  virtual void AddTangent(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, const SystemData& data,
                          double stiffness_scale, double damping_scale, SparseSink* sink) const = 0;
  // Every (row, column) AddTangent may touch.
  virtual void Pattern(SparseSink* sink) const = 0;
  virtual double PotentialEnergy(const Eigen::VectorXd&) const { return 0.0; }
  // An elastic body's internal force, which CGα evaluates over the step (GEMM) instead.
  virtual bool IsElastic() const { return false; }
  // False for an element that can feed energy into the system beyond its PotentialEnergy
  // (time-varying or follower loads): the energy watchdog is then off in AUTO mode.
  virtual bool Passive() const { return true; }
  // A step was accepted (or the run starts) at (q, q̇): elements with a memory update it in
  // `data` (the contact laws' impact speed, the rotors' inflow), which every evaluation is given
  // (the element keeps its slots in it, never a pointer to it). Called by the owner of the run's
  // SystemData, never inside Newton; the element itself keeps nothing that changes.
  virtual void AcceptStep(const Eigen::VectorXd& /*q*/, const Eigen::VectorXd& /*qdot*/, double /*t*/,
                          SystemData* /*data*/) const {}
  // Adaptive steps: the time [s] until a contact this element models would begin at the present
  // rates (its gap over its closing speed), +∞ if none is approaching.
  virtual double TimeToContact(const Eigen::VectorXd& /*q*/, const Eigen::VectorXd& /*qdot*/) const {
    return std::numeric_limits<double>::infinity();
  }
};

// A force F(t) at a body point s and a torque T(t) on the body, both global. In natural
// coordinates the force's virtual work gives f_x = F, f_{u_k} = s_k F; the torque is carried
// by f_{u_k} = ½ T × u_k (a pure couple: Σ_k u_k × ½ T × u_k = T for orthonormal axes).
class AppliedLoad : public ForceElement {
 public:
  AppliedLoad(int body, const Eigen::Vector3d& point, std::array<interface::TimeFunction, 3> force,
              std::array<interface::TimeFunction, 3> torque, bool has_torque);
  void AddForce(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, const SystemData& data,
                Eigen::Ref<Eigen::VectorXd> f) const override;
  void AddTangent(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, const SystemData& data,
                  double stiffness_scale, double damping_scale, SparseSink* sink) const override;
  void Pattern(SparseSink* sink) const override;

  // Its work is not in PotentialEnergy (a torque, or a force that varies in time).
  bool Passive() const override { return false; }

 private:
  Eigen::Vector3d Value(const std::array<interface::TimeFunction, 3>& f, double t) const;
  int offset_;
  Eigen::Vector3d point_;
  std::array<interface::TimeFunction, 3> force_, torque_;
  bool has_torque_;
};

// A spring-damper along the line between two points: F = (k (L − L0) + c L̇) d̂ pulls p2
// towards p1 (d = p2 − p1, L = |d|), and pushes p1 the other way.
class PointSpring : public ForceElement {
 public:
  PointSpring(LinearVector p1, LinearVector p2, double stiffness, double damping, double rest_length);
  void AddForce(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, const SystemData& data,
                Eigen::Ref<Eigen::VectorXd> f) const override;
  void AddTangent(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, const SystemData& data,
                  double stiffness_scale, double damping_scale, SparseSink* sink) const override;
  void Pattern(SparseSink* sink) const override;
  double PotentialEnergy(const Eigen::VectorXd& q) const override;

 private:
  LinearVector d_;  // p2 − p1
  double k_, c_, rest_;
};

// A spring-damper on a joint coordinate θ(q): f = −(k (θ − θ0) + c θ̇) ∇θ. Revolute:
// θ = atan2(b2·c1, b2·b1) (valid within ±π of the initial pose); prismatic: θ = (p2 − p1)·a1.
class CoordinateSpring : public ForceElement {
 public:
  // Revolute form.
  CoordinateSpring(LinearVector b1, LinearVector c1, LinearVector b2, double stiffness, double damping, double rest);
  // Prismatic form.
  CoordinateSpring(LinearVector separation, LinearVector axis, double stiffness, double damping, double rest);
  void AddForce(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, const SystemData& data,
                Eigen::Ref<Eigen::VectorXd> f) const override;
  void AddTangent(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, const SystemData& data,
                  double stiffness_scale, double damping_scale, SparseSink* sink) const override;
  void Pattern(SparseSink* sink) const override;
  double PotentialEnergy(const Eigen::VectorXd& q) const override;

  // The local coordinates of an element between two bodies: at most 2 × 12. Vectors and
  // matrices over them have that as their compile-time bound: no heap in the Newton loop.
  static constexpr int kMaxLocal = 2 * 12;
  using LocalVector = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxLocal, 1>;
  using LocalMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kMaxLocal, kMaxLocal>;
  // θ, its gradient and (with `hessian`) its Hessian over the element's local coordinates.
  // The force needs no Hessian: it is the costly part (a 24 × 24 matrix), made for the tangent.
  struct Local {
    double value = 0.0;
    LocalVector gradient;
    LocalMatrix hessian;  // (empty unless asked for)
  };
  Local Evaluate(const Eigen::VectorXd& q, bool hessian = true) const;
  const std::vector<int>& coordinates() const { return coordinates_; }

 private:
  void Collect();
  bool revolute_;
  LinearVector a_, b_, c_;  // revolute: b1, c1, b2; prismatic: separation, axis, unused
  double k_, damping_, rest_;
  std::vector<int> coordinates_;  // global index of each local coordinate
};

// A one-sided coordinate with the Flores / Hunt–Crossley law (interface/contact/hunt_crossley.h,
// rotor-sailing paper Eq. (8)): δ = side · (θ0 − θ(q)) > 0 is the penetration. θ(q) is the
// signed gap (p − c)·n of a body point against a plane (θ0 = 0, side = +1), or a revolute joint
// angle against a stop (lower: side = +1, upper: side = −1). The generalised force is −f ∇δ.
// δ̇⁻ is a memory: taken at the last accepted state before the penetration (AcceptStep), so it
// is fixed within a step's Newton iterations (an O(h) approximation of the onset speed); it
// lives in SystemData::impact_speed (the slot given at construction), saved with CGα's checkpoints.
using HuntCrossleyLaw = interface::HuntCrossleyLaw;

class UnilateralContact : public ForceElement {
 public:
  // `slot`: its δ̇⁻ in SystemData::impact_speed.
  UnilateralContact(CoordinateSpring measure, double threshold, double side, const HuntCrossleyLaw& law, size_t slot)
      : measure_(std::move(measure)), threshold_(threshold), side_(side), law_(law), slot_(slot) {}
  void AddForce(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, const SystemData& data,
                Eigen::Ref<Eigen::VectorXd> f) const override;
  void AddTangent(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, const SystemData& data,
                  double stiffness_scale, double damping_scale, SparseSink* sink) const override;
  void Pattern(SparseSink* sink) const override { measure_.Pattern(sink); }
  void AcceptStep(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, SystemData* data) const override;
  double TimeToContact(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot) const override;
  // The law's force f >= 0 [N, or N m for a joint stop] at (q, q̇): zero out of contact.
  double LawForce(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, const SystemData& data) const {
    return Evaluate(q, qdot, data).f;
  }
  // The law's elastic part stores K δⁿ⁺¹/(n + 1); its damping part only dissipates.
  double PotentialEnergy(const Eigen::VectorXd& q) const override;

 private:
  // θ with its derivatives, the penetration δ and its rate, and the law's force and partial
  // derivatives at (q, q̇).
  struct State {
    CoordinateSpring::Local measure;
    double delta = 0.0, rate = 0.0;
    double f = 0.0, df_ddelta = 0.0, df_drate = 0.0;
  };
  // θ, δ and δ̇ at q, q̇ (the measure without the Hessian: only the tangent needs that).
  State Measure(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot) const;
  // The same with the law's force (its onset speed from `data`).
  State Evaluate(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, const SystemData& data) const;

  CoordinateSpring measure_;  // θ(q) with gradient and Hessian (zero stiffness: a measure only)
  double threshold_, side_;
  HuntCrossleyLaw law_;
  size_t slot_;  // data.impact_speed[slot_]: δ̇⁻, from the last accepted state without contact
};

}  // namespace cosim::smooth
