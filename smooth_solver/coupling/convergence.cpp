#include "smooth_solver/coupling/convergence.h"

#include <algorithm>
#include <limits>

namespace cosim::smooth {

bool ForceAgreement::operator()(const Eigen::VectorXd& force, const Eigen::VectorXd& held,
                                const std::vector<Eigen::Matrix3d>& stiffness) const {
  const double scale = std::max(1.0, force.size() > 0 ? force.lpNorm<Eigen::Infinity>() : 0.0);
  for (size_t k = 0; k < stiffness.size(); ++k) {
    const Eigen::Index o = 3 * static_cast<Eigen::Index>(k);
    const double floor = stiffness[k].cwiseAbs().rowwise().sum().maxCoeff() * settings_.displacement_tolerance;
    if ((force.segment<3>(o) - held.segment<3>(o)).lpNorm<Eigen::Infinity>() >
        std::max(settings_.reaction_tolerance * scale, floor)) {
      return false;
    }
  }
  return true;
}

bool InterfaceAgreement::Iterate(const CouplingIterate& it, const std::vector<Eigen::Matrix3d>& stiffness,
                                 double frame_drift, CouplingIterationRecord* record) const {
  const PeerAnswers& a = it.answers;
  record->reaction_residual = it.x.size() > 0 ? (it.x_tilde - a.applied).lpNorm<Eigen::Infinity>() : 0.0;
  double mismatch = frame_drift;
  for (size_t k = 0; k < a.sensitivity.size(); ++k) {
    const Eigen::Index o = 3 * static_cast<Eigen::Index>(k);
    mismatch = std::max(
        mismatch, (a.sensitivity[k] * (it.x_tilde.segment<3>(o) - a.applied.segment<3>(o))).lpNorm<Eigen::Infinity>());
  }
  record->displacement_change = mismatch;
  return forces_(it.x_tilde, a.applied, stiffness) && mismatch <= settings_.displacement_tolerance;
}

bool InterfaceAgreement::Linearisation(const CouplingIterate& it, const Eigen::VectorXd& linearised_at,
                                       const std::vector<Eigen::Matrix3d>& stiffness, double frame_drift,
                                       CouplingIterationRecord* record) const {
  const PeerAnswers& a = it.answers;
  record->reaction_residual = it.x.size() > 0 ? (it.x - a.applied).lpNorm<Eigen::Infinity>() : 0.0;
  double mismatch = frame_drift;
  for (size_t k = 0; k < a.sensitivity.size(); ++k) {
    const Eigen::Index o = 3 * static_cast<Eigen::Index>(k);
    mismatch = std::max(mismatch, (a.position.segment<3>(o) - linearised_at.segment<3>(o)).lpNorm<Eigen::Infinity>());
  }
  record->displacement_change = mismatch;
  return forces_(it.x, a.applied, stiffness) && mismatch <= settings_.displacement_tolerance;
}

RelaxationConvergence::Verdict RelaxationConvergence::Test(int iteration, bool free_flight, const CouplingIterate& it,
                                                           const Eigen::VectorXd& previous_x_tilde,
                                                           const Eigen::VectorXd& previous_position,
                                                           CouplingIterationRecord* record) const {
  const bool any = it.x.size() > 0;
  const Eigen::VectorXd& position = it.answers.position;
  const double scale = std::max(1.0, any ? it.x_tilde.lpNorm<Eigen::Infinity>() : 0.0);
  record->reaction_residual = any ? (it.x_tilde - it.x).lpNorm<Eigen::Infinity>() : 0.0;
  record->displacement_change = iteration == 0 ? std::numeric_limits<double>::infinity()
                                               : (position - previous_position).lpNorm<Eigen::Infinity>();
  const double position_roundoff =
      64.0 * std::numeric_limits<double>::epsilon() * std::max(1.0, position.lpNorm<Eigen::Infinity>());
  const bool at_roundoff = iteration > 0 && any && record->displacement_change <= position_roundoff &&
                           record->reaction_residual <= (it.x_tilde - previous_x_tilde).lpNorm<Eigen::Infinity>();
  const bool within = record->reaction_residual <= settings_.reaction_tolerance * scale;
  Verdict v;
  v.converged =
      (within || at_roundoff) && (iteration > 0 ? record->displacement_change <= settings_.displacement_tolerance
                                                : record->reaction_residual == 0.0);
  // coupling.iteration.free_flight_margin: no contact can close within the step: the first
  // iteration is accepted if its reaction residual meets the tolerance, without the second
  // iteration that would confirm the kinematics (the displacement test).
  v.free_flight = iteration == 0 && !v.converged && free_flight && within;
  v.converged = v.converged || v.free_flight;
  v.at_roundoff = v.converged && at_roundoff && !within;
  return v;
}

}  // namespace cosim::smooth
