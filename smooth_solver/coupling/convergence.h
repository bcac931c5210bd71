#pragma once
// The convergence tests of a coupled step's iterations (coupling.iteration's tolerances), one
// class per test; each fills the iteration's record with the residuals it measured.
#include <Eigen/Core>
#include <vector>

#include "smooth_solver/coupling/coupling_method.h"

namespace cosim::smooth {

// Interface Jacobians' force test: per node |x − x̃|∞ <= max(reaction_tolerance · max(1 N, |x|∞),
// ‖E‖∞ displacement_tolerance), x the smooth side's force, x̃ the force the peers held and E the
// smooth side's stiffness at the node. A force mismatch below what displacement_tolerance makes
// through that stiffness (0.2 N for a 2e8 N/m tie at 1e-9 m) is within the kinematic tolerance:
// a node resting on its stop through a stiff tie has its force only to that (5e-15 m of
// position round-off is 1e-6 N).
class ForceAgreement {
 public:
  explicit ForceAgreement(const CouplingSettings& settings) : settings_(settings) {}
  [[nodiscard]] bool operator()(const Eigen::VectorXd& force, const Eigen::VectorXd& held,
                                const std::vector<Eigen::Matrix3d>& stiffness) const;

 private:
  const CouplingSettings& settings_;
};

// Interface Jacobians: the two sides hold one solution of the coupled step when the smooth side's
// force is the one the peers held (ForceAgreement) and the kinematics each side assumed differ
// by at most displacement_tolerance, the moving obstacles' frames included (`frame_drift`).
class InterfaceAgreement {
 public:
  explicit InterfaceAgreement(const CouplingSettings& settings) : settings_(settings), forces_(settings) {}
  // A solve with the peers' affine answer k̃ + S (x − x̃): its force x* against x̃ (the kinematics
  // it assumed differ from the peers' by S (x* − x̃)).
  [[nodiscard]] bool Iterate(const CouplingIterate& it, const std::vector<Eigen::Matrix3d>& stiffness,
                             double frame_drift, CouplingIterationRecord* record) const;
  // The linearising pre-solve (x̂ = it.x at k̂ = `linearised_at`) against the peers' first answer:
  // then the peers' solution k̃ under x̃ = x̂ + E (k̃ − k̂) is the smooth side's too.
  [[nodiscard]] bool Linearisation(const CouplingIterate& it, const Eigen::VectorXd& linearised_at,
                                   const std::vector<Eigen::Matrix3d>& stiffness, double frame_drift,
                                   CouplingIterationRecord* record) const;

 private:
  const CouplingSettings& settings_;
  ForceAgreement forces_;
};

// A relaxation's test: |x̃ − x|∞ <= reaction_tolerance · max(1 N, |x̃|∞) and, after the first
// iteration, |k_i − k_{i−1}|∞ <= displacement_tolerance (at the first, x̃ = x exactly). Once the
// peers' kinematics no longer change beyond round-off, the smooth side's answer cannot settle
// closer than its own jitter between the last two iterations (a stiff tie turns 1e-17 m of
// position round-off into 1e-9 N of reaction): a residual within that jitter passes too.
class RelaxationConvergence {
 public:
  explicit RelaxationConvergence(const CouplingSettings& settings) : settings_(settings) {}
  struct Verdict {
    bool converged = false;
    bool free_flight = false;  // accepted at the first iteration without its confirmation
    bool at_roundoff = false;  // accepted on the round-off rule alone
  };
  // `previous_x_tilde`, `previous_position`: the last iteration's answers; `free_flight`: no
  // contact can close in the step (free_flight_margin), so that the first iteration's residual
  // alone decides.
  [[nodiscard]] Verdict Test(int iteration, bool free_flight, const CouplingIterate& it,
                             const Eigen::VectorXd& previous_x_tilde, const Eigen::VectorXd& previous_position,
                             CouplingIterationRecord* record) const;

 private:
  const CouplingSettings& settings_;
};

}  // namespace cosim::smooth
