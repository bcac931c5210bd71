#include "smooth_solver/coupling/interface_jacobian_method.h"

#include "smooth_solver/constraints/bilinear_constraints.h"

namespace cosim::smooth {

InterfaceJacobianMethod::InterfaceJacobianMethod(const MultibodySystem& system, CgAlpha* integrator,
                                                 const PeerLink& link, const StepReaction& reaction,
                                                 const CouplingSettings& settings, CouplingIterate* it,
                                                 const CouplingMemory* memory, InterfaceRows* rows)
    : system_(system),
      integrator_(integrator),
      link_(link),
      reaction_(reaction),
      settings_(settings),
      it_(it),
      memory_(memory),
      rows_(rows),
      agreement_(settings) {
  const size_t points = system.interface_points.size();
  for (auto* blocks : {&stiffness_, &response_, &response_axes_}) blocks->assign(points, Eigen::Matrix3d::Zero());
  sent_position_ = Eigen::VectorXd::Zero(it->x.size());
}

void InterfaceJacobianMethod::Predict(double h) {
  // The nodes' positions predicted from the accepted steps (no acceleration after an impact)
  // and x (the reactions predicted); the smooth step solved with the peers' last affine answers
  // about them gives a point (x̂, k̂) of the smooth side's own response, and its matrix the
  // slope E: the peers then solve their contact problems for the linearised coupled pair.
  const CouplingMemory& m = *memory_;
  PeerAnswers& a = it_->answers;
  a.velocity = m.accepted_velocity + h * m.accepted_acceleration;
  if (m.offset_known && SameStepLength(h, m.accepted_h) && SameStepLength(h, m.previous_accepted_h)) {
    // The peers' last law k = a_n + S x carried one step on: a_{n+1} = a_n + (k_n − k_{n−1}) +
    // h (v_n − v_{n−1}). For a free node under a constant force (Moreau–Jean, θ-method:
    // k_{n+1} = k_n + h v_n + S (f + x), S = h²θ/m) it is the law the peer will step with, exactly;
    // the pre-solve is then the coupled step, which the peers' answer confirms (PredictionAgrees).
    // A node on its obstacle: second order in the obstacle's motion, as the Taylor predictor below.
    for (size_t k = 0; k < a.sensitivity.size(); ++k) {
      const Eigen::Index o = 3 * static_cast<Eigen::Index>(k);
      a.position.segment<3>(o) = m.accepted_offset.segment<3>(o) +
                                 (m.accepted_position.segment<3>(o) - m.previous_accepted_position.segment<3>(o)) +
                                 h * (m.accepted_velocity.segment<3>(o) - m.previous_accepted_velocity.segment<3>(o)) +
                                 a.sensitivity[k] * it_->x.segment<3>(o);
    }
  } else {
    a.position = m.accepted_position + h * m.accepted_velocity + 0.5 * h * h * m.accepted_acceleration;
  }
  a.applied = it_->x;
}

void InterfaceJacobianMethod::Linearised(double h, bool solved) {
  if (solved) {
    LineariseAtSolve(h);  // (applied = x: the predictor's force)
    return;
  }
  // The predicted node positions with the last answers' compliance were more than CGα could
  // take (observed: the Puma gust at h = 2 ms, 6.638 s, a blade landing on its stop): the
  // predictions themselves (x_0, k_pred) serve as the linearisation point, with the last E.
  sent_position_ = it_->answers.position;
  ++linearisation_fallbacks_;
}

bool InterfaceJacobianMethod::PredictionAgrees(bool solved, CouplingIterationRecord* record) {
  // The pre-solve's force x̂ and kinematics k̂ against the peers' answer: within the tolerances,
  // both sides hold a solution of the coupled step, the smooth side's with the interface at k̂,
  // the peers' at k̃ under x̃ = x̂ + E (k̃ − k̂).
  if (!solved || !settings_.accept_agreeing_linearisation) return false;
  const bool agrees = agreement_.Linearisation(*it_, sent_position_, stiffness_,
                                               link_.FrameDrift(integrator_->state(), it_->answers), record);
  if (agrees) ++linearisation_accepted_;
  return agrees;
}

void InterfaceJacobianMethod::Impose(double h) {
  // k(x) = k̃ + S (x − x̃) with x = κ λ + x_c on the rows p(q) − k − cλ = 0 (Schweizer & Lu's
  // coupling through the constraint, with the peer's answer linearised: Kübler & Schiehlen).
  const double kappa = reaction_.PerMultiplier();
  const PeerAnswers& a = it_->answers;
  for (size_t k = 0; k < system_.interface_points.size(); ++k) {
    const Eigen::Index o = 3 * static_cast<Eigen::Index>(k);
    const Eigen::Matrix3d& S = a.sensitivity[k];
    const Eigen::Vector3d value =
        a.position.segment<3>(o) + S * (reaction_.Constant(static_cast<int>(k), *memory_) - a.applied.segment<3>(o));
    for (int j = 0; j < 3; ++j) rows_->SetPosition(o + j, value(j));
    rows_->SetCompliance(k, kappa * S);
  }
  rows_->SetRates(a.velocity, h);
}

bool InterfaceJacobianMethod::Converged(int /*iteration*/, bool /*free_flight*/, CouplingIterationRecord* record,
                                        bool* skipped) {
  // The smooth step solved with the peers' answers as affine in the force; it agrees with them
  // once its force x* is the one they held (x̃) — then the kinematics it assumed, k̃ + S (x* − x̃),
  // are theirs — and the obstacles' frames are those they stepped with.
  *skipped = false;
  return agreement_.Iterate(*it_, stiffness_, link_.FrameDrift(integrator_->state(), it_->answers), record);
}

void InterfaceJacobianMethod::Next(double h, CouplingIterationRecord* record) {
  LineariseAtSolve(h);
  record->relaxation_factor = 1.0;
}

void InterfaceJacobianMethod::LineariseAtSolve(double h) {
  // The last smooth solve's force x* and the kinematics it assumed, k̃ + S (x* − x̃).
  const PeerAnswers& a = it_->answers;
  for (size_t k = 0; k < a.sensitivity.size(); ++k) {
    const Eigen::Index o = 3 * static_cast<Eigen::Index>(k);
    sent_position_.segment<3>(o) =
        a.position.segment<3>(o) + a.sensitivity[k] * (it_->x_tilde.segment<3>(o) - a.applied.segment<3>(o));
  }
  it_->x = it_->x_tilde;
  UpdateStiffness(h);
}

void InterfaceJacobianMethod::UpdateStiffness(double h) {
  // The smooth side's own response D = ∂λ/∂k (CgAlpha::InterfaceResponse: the peers' compliance
  // not in it; the other points held where they are), x = κλ + x_c.
  if (!integrator_->has_factorization()) return;
  const double kappa = reaction_.PerMultiplier();
  const DaeState& state = integrator_->state();
  if (integrator_->factorizations() != response_factorizations_ || h != response_h_) {
    for (size_t k = 0; k < response_.size(); ++k) {
      response_[k] = kappa * integrator_->InterfaceResponse(static_cast<int>(k), h);
      if (!response_[k].allFinite()) response_[k].setZero();  // (no linearisation rather than a bad one)
      response_axes_[k] = BodyAxes(static_cast<int>(k), state);
    }
    response_factorizations_ = integrator_->factorizations();
    response_h_ = h;
  }
  // A reused matrix is some steps old: the stiffness turns with the body carrying the point (a
  // blade on a spinning hub: 0.56 rad over 20 reused steps of the Puma's), E = R E₀ Rᵀ with
  // R = F F₀ᵀ of its axes.
  for (size_t k = 0; k < response_.size(); ++k) {
    const Eigen::Matrix3d R = BodyAxes(static_cast<int>(k), state) * response_axes_[k].transpose();
    stiffness_[k] = R * response_[k] * R.transpose();
  }
}

Eigen::Matrix3d InterfaceJacobianMethod::BodyAxes(int point, const DaeState& state) const {
  const int body = system_.interface_points[static_cast<size_t>(point)].body;
  return body < 0 ? Eigen::Matrix3d::Identity() : smooth::BodyAxes(state.q, body);
}

}  // namespace cosim::smooth
