#pragma once
// Moreau–Jean θ-method for point masses against planes: the nonsmooth contact dynamics
// (NSCD) timestepping of Eqs. (1)-(5) of the rotor-sailing paper, with Newton's impact law
// and, optionally, Coulomb friction.
//
// With the linear forces of the model (anchor springs, node springs: f = f_e + f_r − K q − C v)
// taken implicitly, per step from t to t + h:
//   M̂ = M + hθC + h²θ²K                                        (iteration matrix)
//   M̂ v_free = M v_k + hθ(f_e,k+1 + f_r − K(q_k + h(1−θ) v_k)) + h(1−θ) f_k
//   v_{k+1} = v_free + M̂⁻¹ G z                                  Eq. (4)
//   q_{k+1} = q_k + h(θ v_{k+1} + (1−θ) v_k)                     Eq. (3b)
// G holds, per active contact, its normal n and (with friction) the tangent directions; z
// the impulses. Frictionless: 0 <= u_{k+1} + e u_k ⟂ r >= 0 with u_{k+1} = W r + u_free,
// W = Gᵀ M̂⁻¹ G (Eqs. (2), (5)). With the polyhedral friction cone (Stewart & Trinkle) each
// frictional contact adds tangent impulses β_j >= 0 along d_j and a sliding-speed multiplier
// λ:  0 <= d_jᵀ v_{k+1} + λ ⟂ β_j >= 0,  0 <= μ r − Σ β_j ⟂ λ >= 0. With Siconos' fc3d the
// exact cone is used instead.
// A contact is active when its predicted gap g_k + (h/2) u_k is at most the settings'
// activation_gap (the index set of the NSCD method, as in Siconos' MoreauJeanOSI with γ = 1/2;
// the small positive threshold keeps resting contacts active through round-off).
//
// Interface Jacobians (co-simulation, docs/protocol.md): the coordinator may linearise the smooth
// side as a force law f_i = f̂_i + E_i (q_{i,k+1} − x̂_i) on interface node i, held over the step
// at the node's end position. Taken implicitly (q_{k+1} = q_k + h(θ v_{k+1} + (1−θ) v_k)), it
// adds −h²θ E_i to the node's block of M̂ and f̂_i + E_i (q_k + h(1−θ) v_k − x̂_i) to its force;
// the LCP then sees the node as tied to the smooth model over the step and finds the contact set
// of the coupled pair. Back, the integrator reports the force it held (applied_forces) and the
// sensitivity of each node's end velocity to a constant force on it at the contact set it found,
// without E (velocity_sensitivity; the position's is hθ times it):
//   ∂v/∂f = h M̂⁻¹ + M̂⁻¹ G_B ∂z_B/∂f,  ∂z_B/∂f = −A_BB⁻¹ ∂b_B/∂f,  ∂b/∂f = Gᵀ h M̂⁻¹ on the
// impulse rows (0 on the sliding multipliers'), B the LCP's basic variables (z > 0): the
// derivative of the piecewise-affine map f ↦ v_{k+1} on the piece the solution lies in, exact for
// the frictionless and the polyhedral-friction LCP. With Siconos' fc3d (exact cone) a sticking
// contact fixes its three directions and a sliding one its normal velocity, its impulse along
// n − μ s with the sliding direction s turning with the tangential velocity (exact on the piece).
//
// Nodes linked by springs form groups (ContactModel::groups); M̂ is block diagonal over
// groups, so each group's M̂ is factored apart (once per step size), and contacts of
// different groups do not interact: with split_independent_lcps each group's contacts make
// an LCP of their own, which has the same solution as the one block-diagonal LCP.
#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <vector>

#include "nonsmooth_solver/integrator/moreau_jean_settings.h"
#include "nonsmooth_solver/model/contact_model.h"

namespace cosim::nonsmooth {

struct MoreauJeanStats {
  long long lcp_solves = 0;
  long long lcp_iterations = 0;  // summed solver iterations (LCP or fc3d)
  long long lcp_fallbacks = 0;
  long long activations = 0;  // contacts in an index set, summed over steps
  int max_step_lcp_iterations = 0;
  int last_step_lcp_iterations = 0;
  int last_step_active = 0;
};

class MoreauJean {
 public:
  // Starts from the model's initial positions and velocities at time `start_time`, integrating
  // with `settings`. The model must outlive the integrator (it is referenced, not copied).
  MoreauJean(const ContactModel& model, const MoreauJeanSettings& settings, double start_time);
  MoreauJean(ContactModel&&, const MoreauJeanSettings&, double) = delete;
  const MoreauJeanSettings& settings() const { return settings_; }

  // Advances q, v from t to t + h. Throws NumericalError (state unchanged) if a contact
  // problem fails its check and no fallback rescues it.
  void Step(double t, double h);

  // An external force per node [N], held constant over the next steps (the coupling peer's
  // reaction). Size 3 × nodes.
  void SetExternalForces(const Eigen::Ref<const Eigen::VectorXd>& forces) { external_ = forces; }
  // The smooth side's linearisation (see the top): `stiffness` 9 per node (E_i row-major, zero
  // for a node without), `reference` 3 per node (x̂_i). Held until cleared.
  void SetInterfaceStiffness(const Eigen::Ref<const Eigen::VectorXd>& stiffness,
                             const Eigen::Ref<const Eigen::VectorXd>& reference);
  void ClearInterfaceStiffness() { stiffness_.resize(0); }
  // The force held on each node over the last step: external + E (q_{k+1} − x̂) (3 per node).
  const Eigen::VectorXd& applied_forces() const { return applied_; }
  // Whether each step computes velocity_sensitivity (off by default: a standalone run needs none).
  void set_compute_sensitivities(bool on) { sensitivities_on_ = on; }
  // ∂v_{k+1}/∂f of each node for a constant force f on it (9 per node, row-major 3 × 3), at the
  // last step's contact set, without the interface stiffness (see the top).
  const Eigen::VectorXd& velocity_sensitivity() const { return velocity_sensitivity_; }

  // Puts node `node` (model order) at x [m] with velocity v [m/s] (a settled start's nodes).
  void SetNodeState(int node, const Eigen::Vector3d& x, const Eigen::Vector3d& v) {
    q_.segment<3>(3 * static_cast<Eigen::Index>(node)) = x;
    v_.segment<3>(3 * static_cast<Eigen::Index>(node)) = v;
  }
  const Eigen::VectorXd& positions() const { return q_; }   // 3 per node, model order
  const Eigen::VectorXd& velocities() const { return v_; }  // 3 per node
  // Normal impulse [N s] of each contact in the last step (0 if it was not active).
  const Eigen::VectorXd& impulses() const { return impulse_; }
  // Tangential (friction) impulse vector [N s] of each contact in the last step: 3 × contacts.
  const Eigen::MatrixXd& friction_impulses() const { return friction_impulse_; }
  double time() const { return time_; }
  double Gap(int contact) const;
  double GapRate(int contact) const;       // [m/s] at the current time (the node's velocity against the plane's)
  double KineticEnergy(int node) const;    // node < 0: all nodes
  double PotentialEnergy(int node) const;  // gravity and springs; node < 0: all (node springs included)
  const MoreauJeanStats& stats() const { return stats_; }
  // The driven obstacles' frames: the step's input, which the coupling server writes (the
  // checkpoints below do not hold them).
  const ContactData& data() const { return data_; }
  ContactData* mutable_data() { return &data_; }

  // The state a step changes, to try a step again (a coupling iteration) or undo it (a
  // rejected step). SaveTo reuses the checkpoint's buffers: no allocation once sized.
  struct Checkpoint {
    double time = 0.0;
    Eigen::VectorXd q, v, impulse;
    Eigen::MatrixXd friction_impulse;
    MoreauJeanStats stats;
  };
  void SaveTo(Checkpoint* c) const {
    c->time = time_;
    c->q = q_;
    c->v = v_;
    c->impulse = impulse_;
    c->friction_impulse = friction_impulse_;
    c->stats = stats_;
  }
  void Restore(const Checkpoint& c) {
    time_ = c.time;
    q_ = c.q;
    v_ = c.v;
    impulse_ = c.impulse;
    friction_impulse_ = c.friction_impulse;
    stats_ = c.stats;
  }

 private:
  // Constant matrices and scratch of one node group, sized once.
  struct GroupWork {
    int dofs = 0;
    Eigen::VectorXd mass;            // per dof
    Eigen::MatrixXd K, C;            // dofs × dofs
    Eigen::VectorXd f_rest;          // constant part of the spring forces
    bool has_linear_forces = false;  // K or C non-zero
    bool diagonal = true;            // M̂ diagonal (no node springs): solve by division
    Eigen::LLT<Eigen::MatrixXd> m_hat;
    Eigen::MatrixXd m_hat_matrix;
    Eigen::VectorXd m_hat_diagonal;
    double factored_h = -1.0;
    Eigen::MatrixXd m_hat_inverse;  // M̂⁻¹ without the interface stiffness (sensitivities), with factored_h
    // This step's M̂ − h²θ E (an interface stiffness on one of the group's nodes): LU, since E
    // need not be symmetric.
    bool coupled = false;
    Eigen::PartialPivLU<Eigen::MatrixXd> m_hat_coupled;
    Eigen::VectorXd q, v, fe0, fe1, rhs, v_free;
    Eigen::MatrixXd G, Y;   // dofs × (max columns)
    int columns = 0;        // impulse columns this step (0: no active contact)
    int column_offset = 0;  // first column in the assembled problem
  };
  // Where one active contact's unknowns sit in the assembled problem.
  struct ActiveContact {
    int contact = 0;
    int group = 0;
    int normal_column = 0;    // column within its group
    int tangent_columns = 0;  // polyhedral facets (0 without friction)
    int lambda_row = -1;      // sliding multiplier row (polyhedral friction), in the problem
    double u0 = 0.0;          // normal velocity at the start of the step
  };

  void FreeVelocity(int group, double t, double h);
  // x ← M̂⁻¹ x for the group's M̂ of this step (with the interface stiffness, if any).
  void SolveMHat(const GroupWork& w, Eigen::Ref<Eigen::MatrixXd> x) const;
  // velocity_sensitivity_ of the groups' nodes: free (no active contact) or after the contact
  // problem of `groups` was solved (A_, z_ hold it).
  void FreeSensitivity(int group, double h);
  void ContactSensitivity(const std::vector<int>& groups, int size, double t1, double h);
  // ContactSensitivity's blocks over the groups' dofs together: V0 = h M̂⁻¹, Y_u = M̂⁻¹ G, G.
  struct SensitivityBlocks {
    Eigen::MatrixXd V0, Yu, G;
    int dofs = 0, columns = 0;
  };
  Eigen::MatrixXd LcpPieceSensitivity(const SensitivityBlocks& b, int size) const;
  Eigen::MatrixXd Fc3dPieceSensitivity(const std::vector<int>& groups, const SensitivityBlocks& b, int size, double t1,
                                       double h) const;
  // Builds G (and Y = M̂⁻¹ G) for the group's active contacts.
  void BuildColumns(int group, double t1);
  // Assembles and solves the contact problem of `groups`, then updates their v_free.
  void SolveContacts(const std::vector<int>& groups, double t1, double h);
  Eigen::Vector3d FacetDirection(const Obstacle& ob, double t, int j) const;

  const ContactModel& model_;
  MoreauJeanSettings settings_;
  ContactData data_;
  LcpSolver lcp_;
  double time_ = 0.0;
  Eigen::VectorXd q_, v_, impulse_, external_;
  Eigen::VectorXd stiffness_, reference_, applied_;  // interface stiffness (empty: none), x̂, held force
  bool sensitivities_on_ = false;
  Eigen::VectorXd velocity_sensitivity_;
  Eigen::MatrixXd friction_impulse_;
  std::vector<GroupWork> work_;
  std::vector<ActiveContact> active_;  // all groups, this step
  std::vector<int> first_active_;      // per group: index into active_
  // Assembled problem, sized for every contact with friction.
  Eigen::MatrixXd A_;
  Eigen::VectorXd b_, z_, mu_;
  std::vector<int> all_groups_, one_group_;
  MoreauJeanStats stats_;
};

}  // namespace cosim::nonsmooth
