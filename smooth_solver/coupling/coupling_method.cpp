#include "smooth_solver/coupling/coupling_method.h"

namespace cosim::smooth {

CouplingIterate::CouplingIterate(int points) {
  x = x_tilde = Eigen::VectorXd::Zero(3 * points);
  answers.position = answers.velocity = answers.applied = x;
  answers.sensitivity.assign(static_cast<size_t>(points), Eigen::Matrix3d::Zero());
  answers.contact.assign(static_cast<size_t>(points), false);
}

void InterfaceRows::BeginStep(int values) {
  start_velocity_.resize(values);
  for (Eigen::Index v = 0; v < values; ++v) start_velocity_(v) = data_->imposed[static_cast<size_t>(v)].rate;
}

namespace {

void SetRatesOf(const Eigen::VectorXd& velocity, const Eigen::VectorXd& start_velocity, double h,
                std::vector<ImposedCoordinate>* imposed) {
  for (Eigen::Index v = 0; v < velocity.size(); ++v) {
    ImposedCoordinate& c = (*imposed)[static_cast<size_t>(v)];
    c.rate = velocity(v);
    c.acceleration = (velocity(v) - start_velocity(v)) / h;
  }
}

}  // namespace

void InterfaceRows::SetRates(const Eigen::VectorXd& velocity, double h) {
  SetRatesOf(velocity, start_velocity_, h, &motion_.imposed);
}

void InterfaceRows::SetSolvedRates(const Eigen::VectorXd& velocity, double h) {
  SetRatesOf(velocity, start_velocity_, h, &data_->imposed);
}

StepReaction::StepReaction(const MultibodySystem& system, const CgAlpha& integrator, bool step_average)
    : system_(system), integrator_(integrator), step_average_(step_average) {
  lambda_end_ = filtered_end_ = Eigen::VectorXd::Zero(3 * static_cast<Eigen::Index>(system.interface_points.size()));
}

void StepReaction::StartFrom(const DaeState& state, CouplingMemory* memory) const {
  for (size_t k = 0; k < system_.interface_points.size(); ++k) {
    memory->lambda_start.segment<3>(3 * static_cast<Eigen::Index>(k)) =
        system_.InterfaceReaction(static_cast<int>(k), state.lambda);
  }
  memory->filtered_start = memory->lambda_start;
}

void StepReaction::FromSolve(const Eigen::VectorXd& lambda, const CouplingMemory& memory, Eigen::VectorXd* x_tilde) {
  for (size_t k = 0; k < system_.interface_points.size(); ++k) {
    lambda_end_.segment<3>(3 * static_cast<Eigen::Index>(k)) = system_.InterfaceReaction(static_cast<int>(k), lambda);
  }
  // STEP_AVERAGE: the multipliers through CGα's acceleration filter
  // (1 − α_m) λ̃₁ + α_m λ̃₀ = (1 − α_f) λ₁ + α_f λ₀, weighted as its velocity update,
  // (1 − γ) λ̃₀ + γ λ̃₁: h times it is the momentum the smooth side exchanged with the node
  // over the step. END_OF_STEP: λ₁.
  const double am = integrator_.alpha_m(), af = integrator_.alpha_f();
  filtered_end_ = ((1.0 - af) * lambda_end_ + af * memory.lambda_start - am * memory.filtered_start) / (1.0 - am);
  if (step_average_) {
    *x_tilde = (1.0 - integrator_.gamma()) * memory.filtered_start + integrator_.gamma() * filtered_end_;
  } else {
    *x_tilde = lambda_end_;
  }
}

void StepReaction::Accept(CouplingMemory* memory) const {
  memory->lambda_start = lambda_end_;
  memory->filtered_start = filtered_end_;
}

double StepReaction::PerMultiplier() const {
  // ∂x̃/∂λ₁ of the two forms above.
  if (!step_average_) return 1.0;
  return integrator_.gamma() * (1.0 - integrator_.alpha_f()) / (1.0 - integrator_.alpha_m());
}

Eigen::Vector3d StepReaction::Constant(int point, const CouplingMemory& memory) const {
  if (!step_average_) return Eigen::Vector3d::Zero();
  const Eigen::Index o = 3 * static_cast<Eigen::Index>(point);
  const double g = integrator_.gamma(), am = integrator_.alpha_m(), af = integrator_.alpha_f();
  return (1.0 - g) * memory.filtered_start.segment<3>(o) +
         g * (af * memory.lambda_start.segment<3>(o) - am * memory.filtered_start.segment<3>(o)) / (1.0 - am);
}

}  // namespace cosim::smooth
