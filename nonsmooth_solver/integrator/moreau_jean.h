#pragma once
// Moreau–Jean θ-method for point masses against planes: the nonsmooth contact dynamics
// (NSCD) timestepping of Eqs. (1)-(5) of the rotor-sailing paper, frictionless, with Newton's
// impact law. One LCP per step over every active contact of every node, solved through
// Siconos Numerics (lcp/lcp_solver.h).
//
// Per node, with the linear spring-damper (k, c) of the model taken implicitly:
//   M̂ = m + hθc + h²θ²k                                  (iteration "mass")
//   M̂ v_free = m v_k + hθ(fe_{k+1} − k(q_k − a + h(1−θ) v_k)) + h(1−θ) f_k
//   v_{k+1} = v_free + M̂⁻¹ H r                            Eq. (4)
//   u = Hᵀ v + b(t, q)  (b: the plane's own motion)
//   0 <= u_{k+1} + e u_k ⟂ r >= 0,  u_{k+1} = W r + u_free  Eq. (2), (5), W = Hᵀ M̂⁻¹ H
//   q_{k+1} = q_k + h(θ v_{k+1} + (1−θ) v_k)               Eq. (3b)
// A contact enters the LCP when its predicted gap g_k + (h/2) u_k is at most the model's
// activation_gap (the index set of the NSCD method, as in Siconos' MoreauJeanOSI with
// γ = 1/2; the small positive threshold keeps resting contacts active through round-off).
#include <Eigen/Core>

#include "nonsmooth_solver/model/contact_model.h"

namespace cosim::nonsmooth {

struct MoreauJeanStats {
  long long lcp_solves = 0;
  long long lcp_iterations = 0;   // summed Siconos iterations
  long long lcp_fallbacks = 0;
  long long activations = 0;      // contacts entering the index set
  int max_step_lcp_iterations = 0;
  int last_step_lcp_iterations = 0;
  int last_step_active = 0;
};

class MoreauJean {
 public:
  // Starts from the model's initial positions and velocities at time `start_time`.
  MoreauJean(const ContactModel& model, double start_time);

  // Advances q, v from t to t + h. Throws NumericalError (state unchanged) if the LCP fails
  // its complementarity check and no fallback rescues it.
  void Step(double t, double h);

  // An external force per node [N], held constant over the next steps (the coupling peer's
  // reaction). Size 3 × nodes.
  void SetExternalForces(const Eigen::Ref<const Eigen::VectorXd>& forces) { external_ = forces; }

  const Eigen::VectorXd& positions() const { return q_; }   // 3 per node
  const Eigen::VectorXd& velocities() const { return v_; }  // 3 per node
  // Impulse [N s] of each contact in the last step (0 if it was not active).
  const Eigen::VectorXd& impulses() const { return impulse_; }
  double time() const { return time_; }
  double Gap(int contact) const;
  double KineticEnergy(int node) const;    // node < 0: all nodes
  double PotentialEnergy(int node) const;  // gravity and springs
  const MoreauJeanStats& stats() const { return stats_; }

 private:
  const ContactModel& model_;
  LcpSolver lcp_;
  double time_ = 0.0;
  Eigen::VectorXd q_, v_, impulse_, external_;
  // Workspace, sized once (the LCP matrices to the largest possible active set).
  Eigen::VectorXd v_free_, mass_hat_;
  std::vector<int> active_;
  Eigen::MatrixXd W_;
  Eigen::VectorXd q_lcp_, z_;
  Eigen::MatrixXd normals_;  // 3 × contacts, n at t + h
  MoreauJeanStats stats_;
};

}  // namespace cosim::nonsmooth
