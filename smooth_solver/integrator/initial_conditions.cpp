#include "smooth_solver/integrator/initial_conditions.h"

#include <kinsol/kinsol.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sunlinsol/sunlinsol_klu.h>
#include <sunmatrix/sunmatrix_sparse.h>

#include <algorithm>
#include <limits>
#include <optional>

#include "interface/base/errors.h"
#include "interface/scenario/checks.h"
#include "smooth_solver/linear_algebra/fixed_pattern_matrix.h"
#include "smooth_solver/linear_algebra/hub_columns.h"
#include "smooth_solver/linear_algebra/klu_ordering.h"
#include "smooth_solver/linear_algebra/sun_sparse.h"

namespace cosim::smooth {

namespace {

struct ClosureProblem {
  const MultibodySystem* system;
  const SystemData* data;  // the run's changing state (its imposed coordinates)
  // The constraints as the closure sees them: the system's, with the locks set by the closure
  // (Joint.lock_at_closure) released.
  const ConstraintSet* constraints;
  double t0;
  int n, mc, mh;
  Eigen::SparseMatrix<double> A;  // the Jacobian, its pattern fixed (KLU, not a dense N × N)
};

Eigen::Map<Eigen::VectorXd> View(N_Vector v) {
  return Eigen::Map<Eigen::VectorXd>(N_VGetArrayPointer(v), N_VGetLength(v));
}

// F(q, μ) = [q − q₀ + Φ_qᵀ μ_c + H_qᵀ μ_h; Φ(q) − C μ_c; H(q)]: the KKT conditions of
// min ½|q − q₀|² subject to the constraints and the holds; regularised rows (compliance C,
// Eq. (7) of the rotor-sailing paper) are met in the least-squares sense, which keeps a loop
// closed by redundant coupling rows solvable.
int Residual(N_Vector y, N_Vector f, void* data) {
  const auto* p = static_cast<const ClosureProblem*>(data);
  const auto Y = View(y);
  auto F = View(f);
  const Eigen::VectorXd q = Y.head(p->n);
  F.head(p->n) = q - p->system->q0;
  p->constraints->AddJacobianTransposeTimes(p->data->imposed, q, p->t0, Y.segment(p->n, p->mc), F.head(p->n));
  p->system->holds.AddJacobianTransposeTimes(p->data->imposed, q, p->t0, Y.tail(p->mh), F.head(p->n));
  p->constraints->Evaluate(p->data->imposed, q, p->t0, F.segment(p->n, p->mc));
  for (int i = 0; i < p->mc; ++i) F(p->n + i) -= p->constraints->Compliance(static_cast<size_t>(i)) * Y(p->n + i);
  for (int i = 0; i < p->mc; ++i) {
    if (!p->constraints->Active(static_cast<size_t>(i), p->t0)) F(p->n + i) = Y(p->n + i);  // released: μ = 0
  }
  p->system->holds.Evaluate(p->data->imposed, q, p->t0, F.tail(p->mh));
  return F.allFinite() ? 0 : 1;
}

// The KKT matrix [I + Σ μ ∂²φ/∂q², Φ_qᵀ, H_qᵀ; Φ_q, −C, 0; H_q, 0, 0] (released rows: 1 on
// the diagonal) into `sink`.
void FillJacobian(const ClosureProblem& p, const Eigen::Ref<const Eigen::VectorXd>& Y, SparseSink* sink) {
  const Eigen::VectorXd q = Y.head(p.n);
  for (int i = 0; i < p.n; ++i) sink->Add(i, i, 1.0);
  p.constraints->HessianTimesLambda(p.data->imposed, p.t0, Y.segment(p.n, p.mc), sink, 1.0);
  p.system->holds.HessianTimesLambda(p.data->imposed, p.t0, Y.tail(p.mh), sink, 1.0);
  p.constraints->Jacobian(p.data->imposed, q, p.t0, sink, p.n, 1.0);
  p.constraints->JacobianTranspose(p.data->imposed, q, p.t0, sink, p.n, 1.0);
  p.constraints->AddReleasedDiagonal(p.t0, sink, p.n);
  p.constraints->AddComplianceDiagonal(sink, p.n, 1.0);
  p.system->holds.Jacobian(p.data->imposed, q, p.t0, sink, p.n + p.mc, 1.0);
  p.system->holds.JacobianTranspose(p.data->imposed, q, p.t0, sink, p.n + p.mc, 1.0);
}

// Every entry FillJacobian may touch (and the whole diagonal, for the released rows).
Eigen::SparseMatrix<double> JacobianPattern(const ClosureProblem& p) {
  const int N = p.n + p.mc + p.mh;
  const double always = -std::numeric_limits<double>::infinity();
  PatternSink pattern;
  for (int i = 0; i < N; ++i) pattern.Add(i, i, 0.0);
  p.constraints->HessianPattern(&pattern);
  p.system->holds.HessianPattern(&pattern);
  p.constraints->Jacobian(p.data->imposed, p.system->q0, always, &pattern, p.n, 1.0);
  p.constraints->JacobianTranspose(p.data->imposed, p.system->q0, always, &pattern, p.n, 1.0);
  p.system->holds.Jacobian(p.data->imposed, p.system->q0, always, &pattern, p.n + p.mc, 1.0);
  p.system->holds.JacobianTranspose(p.data->imposed, p.system->q0, always, &pattern, p.n + p.mc, 1.0);
  return pattern.Build(N, N);
}

int Jacobian(N_Vector y, N_Vector, SUNMatrix J, void* data, N_Vector, N_Vector) {
  auto* p = static_cast<ClosureProblem*>(data);
  for (Eigen::Index k = 0; k < p->A.nonZeros(); ++k) p->A.valuePtr()[k] = 0.0;
  MatrixSink sink(&p->A);
  FillJacobian(*p, View(y), &sink);
  CopyToSunSparse(p->A, J);
  return 0;
}

// min ½|q̇ − q̇_ref|²_W s.t. Φ_q q̇ = −Φ_t and, with `holds`, H_q q̇ = H_q q̇_ref (held joint
// speeds kept): the KKT system [W Gᵀ; G −C], C the rows' compliance (regularised rows are met
// in the least-squares sense), W = I or, with `mass_metric`, the mass matrix: then the change is
// the one an impulse through the constraints makes (M Δq̇ = Gᵀ P), which spreads over an elastic
// body as its inertia does instead of landing on the constrained nodes alone. Returns false if
// it is singular (redundant rows not regularised).
bool SmallestVelocityChange(const MultibodySystem& system, const SystemData& data, const ConstraintSet* holds, double t,
                            const Eigen::VectorXd& q, const Eigen::VectorXd& qdot_ref, Eigen::VectorXd* qdot,
                            bool mass_metric = false) {
  const int n = system.coordinates, mc = system.constraints.size(), mh = holds != nullptr ? holds->size() : 0;
  const int N = n + mc + mh;
  PatternSink pattern;
  for (int i = 0; i < N; ++i) pattern.Add(i, i, 0.0);
  if (mass_metric) AddSparse(system.mass, 1.0, &pattern);
  system.constraints.Jacobian(data.imposed, q, t, &pattern, n, 1.0);
  system.constraints.JacobianTranspose(data.imposed, q, t, &pattern, n, 1.0);
  if (holds != nullptr) {
    holds->Jacobian(data.imposed, q, t, &pattern, n + mc, 1.0);
    holds->JacobianTranspose(data.imposed, q, t, &pattern, n + mc, 1.0);
  }
  Eigen::SparseMatrix<double> A = pattern.Build(N, N);
  MatrixSink sink(&A);
  if (mass_metric) {
    AddSparse(system.mass, 1.0, &sink);
  } else {
    for (int i = 0; i < n; ++i) sink.Add(i, i, 1.0);
  }
  system.constraints.Jacobian(data.imposed, q, t, &sink, n, 1.0);
  system.constraints.JacobianTranspose(data.imposed, q, t, &sink, n, 1.0);
  system.constraints.AddReleasedDiagonal(t, &sink, n);
  system.constraints.AddComplianceDiagonal(&sink, n, 1.0);
  if (holds != nullptr) {
    holds->Jacobian(data.imposed, q, t, &sink, n + mc, 1.0);
    holds->JacobianTranspose(data.imposed, q, t, &sink, n + mc, 1.0);
  }
  Eigen::VectorXd rhs(N);
  rhs.head(n) = mass_metric ? Eigen::VectorXd(system.mass * qdot_ref) : qdot_ref;
  system.constraints.TimeDerivative(data.imposed, q, t, rhs.segment(n, mc));
  rhs.segment(n, mc) *= -1.0;
  if (holds != nullptr) holds->JacobianTimes(data.imposed, q, t, qdot_ref, rhs.tail(mh));
  const int rigid = system.rigid_coordinates();
  KluSolver lu;
  bool factorized = FactorizeHubLast(&A, rigid, &lu);
  if (!factorized && mh > 0) {
    // A held speed the constraints already fix (a held joint of a structure the closure made
    // rigid, e.g. with an actuator locked at closure) makes its row redundant: met in the
    // least-squares sense instead (consistent, as here, it costs nothing).
    for (int i = 0; i < mh; ++i) A.coeffRef(n + mc + i, n + mc + i) -= 1e-12;
    factorized = FactorizeHubLast(&A, rigid, &lu);
  }
  if (!factorized) return false;
  lu.SolveInPlace(rhs);
  *qdot = rhs.head(n);
  return true;
}

}  // namespace

DaeState ConsistentInitialState(const MultibodySystem& system, const SystemData& data, double t0,
                                InitialConditionReport* report) {
  const int n = system.coordinates, mc = system.constraints.size(), mh = system.holds.size();
  const int N = n + mc + mh;
  // Locks whose value the closure chooses are not part of it (Joint.lock_at_closure).
  std::optional<ConstraintSet> closure_constraints;
  const auto& rows = system.constraints.constraints;
  if (std::any_of(rows.begin(), rows.end(), [](const ScalarConstraint& c) { return c.set_by_closure; })) {
    closure_constraints = system.constraints;
    for (ScalarConstraint& c : closure_constraints->constraints) {
      if (c.set_by_closure) c.release_time = -std::numeric_limits<double>::infinity();  // released: left out
    }
  }
  ClosureProblem problem{&system, &data, closure_constraints ? &*closure_constraints : &system.constraints, t0, n, mc,
                         mh,      {}};
  problem.A = JacobianPattern(problem);

  SUNContext ctx = nullptr;
  SUNContext_Create(nullptr, &ctx);
  N_Vector y = N_VNew_Serial(N, ctx);
  N_Vector scale = N_VNew_Serial(N, ctx);
  SUNMatrix J = SUNSparseMatrix(N, N, problem.A.nonZeros(), CSC_MAT, ctx);
  SUNLinearSolver LS = SUNLinSol_KLU(y, J, ctx);
  // A hub's coordinates last, as in CGα's matrices (hub_columns.h): the closure's Jacobian has
  // their coupling, and on a 100-blade Puma its factorisation was 9 % of a two-step run.
  std::vector<sunindextype> sets;
  const int rigid = system.rigid_coordinates();
  OrderColumnsLast(SUNLinSol_KLUGetCommon(LS), N, HubColumns(problem.A, RigidBodyGroups(rigid, N)), &sets);
  void* kin = KINCreate(ctx);
  View(y).setZero();
  View(y).head(n) = system.q0;
  N_VConst(1.0, scale);
  KINInit(kin, Residual, y);
  KINSetUserData(kin, &problem);
  KINSetErrHandlerFn(
      kin, [](int, const char*, const char*, char*, void*) {}, nullptr);  // reported below
  KINSetLinearSolver(kin, LS, J);
  KINSetJacFn(kin, Jacobian);
  KINSetFuncNormTol(kin, 1e-13);
  KINSetScaledStepTol(kin, 1e-15);
  KINSetMaxSetupCalls(kin, 1);  // exact Newton: a fresh Jacobian every iteration
  KINSetNumMaxIters(kin, 200);
  const int flag = KINSol(kin, y, KIN_LINESEARCH, scale, scale);
  long iterations = 0;
  KINGetNumNonlinSolvIters(kin, &iterations);
  double fnorm = 0.0;
  KINGetFuncNorm(kin, &fnorm);
  DaeState state;
  state.q = View(y).head(n);
  KINFree(&kin);
  SUNLinSolFree(LS);
  SUNMatDestroy(J);
  N_VDestroy(y);
  N_VDestroy(scale);
  SUNContext_Free(&ctx);
  if (flag == KIN_LSETUP_FAIL || flag == KIN_LSOLVE_FAIL) {
    // Rigid coupling ties are named: two of them on one body that has a single degree of freedom
    // (the pads of a teetering yoke) are the usual loop, and a compliance lets the rotor run.
    std::string ties;
    for (const InterfacePoint& p : system.interface_points) {
      if (p.regularization == 0.0) ties += (ties.empty() ? "'" : ", '") + p.contact_node + "'";
    }
    throw InputError(
        "model: the constraint equations are redundant: the loop-closure matrix is singular at the "
        "given poses (KINSOL flag " +
        std::to_string(flag) + ", residual " + interface::FormatNumber(fnorm) + ")" +
        (ties.empty() ? std::string()
                      : "; the rigid coupling ties (regularization 0) of contact nodes " + ties +
                            " hold their bodies as joints do: two on one body with a single degree of freedom "
                            "(the pads of a teetering yoke) close a loop, which a compliance opens "
                            "(coupling.interface_nodes[].regularization > 0: the Puma scenes' 5e-9 m/N)") +
        ". Otherwise e.g. a planar loop of revolute joints in 3D: make one joint less constraining (spherical, "
        "universal)");
  }
  if (flag < 0 || !(fnorm < 1e-8)) {
    throw InputError("model: the kinematic loops cannot be closed from the given poses (KINSOL flag " +
                     std::to_string(flag) + ", residual " + interface::FormatNumber(fnorm) + " after " +
                     std::to_string(iterations) +
                     " iterations); check the joints' body-frame points and the bodies' initial poses");
  }
  if (report != nullptr) {
    report->kinsol_iterations = iterations;
    report->position_change = (state.q - system.q0).lpNorm<Eigen::Infinity>();
  }

  // Velocities: min ½|q̇ − q̇₀|² s.t. Φ_q q̇ = −Φ_t, H_q q̇ = H_q q̇₀ (held joint speeds kept).
  if (!SmallestVelocityChange(system, data, &system.holds, t0, state.q, system.qdot0, &state.qdot)) {
    throw InputError(
        "model: the velocity constraints are singular at the initial state (redundant joints, or coincidence rows "
        "that close a loop: give coupling.interface_nodes[].regularization)");
  }
  if (report != nullptr) report->velocity_change = (state.qdot - system.qdot0).lpNorm<Eigen::Infinity>();
  ConsistentAccelerations(system, data, t0, &state);
  return state;
}

void ProjectVelocities(const MultibodySystem& system, const SystemData& data, double t, DaeState* state) {
  const Eigen::VectorXd reference = state->qdot;
  if (!SmallestVelocityChange(system, data, nullptr, t, state->q, reference, &state->qdot, /*mass_metric=*/true)) {
    throw NumericalError("the velocity constraints are singular at t = " + interface::FormatNumber(t) +
                         " s (redundant rows: regularise the coupling rows of a closed loop)");
  }
}

namespace {

// Every elastic (hex27) body's node coordinates.
std::vector<bool> Hex27Coordinates(const MultibodySystem& system) {
  std::vector<bool> held(static_cast<size_t>(system.coordinates), false);
  for (size_t e = 0; e < system.elastic.size(); ++e) {
    const int first = system.elastic_offset[e], count = 3 * system.elastic[e]->body.node_count();
    for (int j = 0; j < count; ++j) held[static_cast<size_t>(first + j)] = true;
  }
  return held;
}

// The coordinates an impact's restart leaves as they are: every beam node's and every elastic
// (hex27) body's.
std::vector<bool> ElasticCoordinates(const MultibodySystem& system) {
  std::vector<bool> held = Hex27Coordinates(system);
  for (const std::vector<int>& nodes : system.beam_node_bodies) {
    for (int b : nodes) {
      for (int j = 0; j < kCoordinatesPerBody; ++j) held[static_cast<size_t>(kCoordinatesPerBody * b + j)] = true;
    }
  }
  return held;
}

// The matrix of an impact's restart at positions q: [M Φ_qᵀ; Φ_q −C] over the rigid bodies'
// coordinates, the elastic coordinates' rows and columns (`held`) and the other points' coupling
// rows (those not in `points`) replaced by identity rows. Rows that only held coordinates enter
// (a beam's own frames) are then empty: every row gets a compliance of 1e-10 (an impulse of
// 1 kN s meets its row to 1e-7 m/s) where anything is held; without, the rows are exact (a tied
// drop's restart, as before). `out(i)`: the row or column i is an identity one.
struct ImpactMatrix {
  Eigen::SparseMatrix<double> full, A;  // before and after the identity rows
  std::vector<bool> out;
  Eigen::SparseMatrix<double> turn;  // the rows turned to each normal's frame (empty: none)
  // The right-hand side of [q̇ or Δq; rows] in the matrix's rows.
  Eigen::VectorXd Turned(const Eigen::VectorXd& rhs) const {
    return turn.size() == 0 ? rhs : Eigen::VectorXd(turn * rhs);
  }
};
ImpactMatrix BuildImpactMatrix(const MultibodySystem& system, const SystemData& data, double t,
                               const Eigen::VectorXd& q, const std::vector<bool>& held, const std::vector<int>& points,
                               bool regularised = false, const ImpactNormals* normals = nullptr) {
  const int n = system.coordinates, mc = system.constraints.size(), N = n + mc;
  constexpr double kRedundancy = 1e-10;
  ImpactMatrix m;
  m.out = held;  // (n coordinates, then the rows)
  m.out.resize(static_cast<size_t>(N), false);
  for (size_t k = 0; k < system.interface_points.size(); ++k) {
    if (std::find(points.begin(), points.end(), static_cast<int>(k)) != points.end()) continue;
    for (int j = 0; j < 3; ++j) m.out[static_cast<size_t>(n + system.interface_points[k].first_row + j)] = true;
  }
  const bool any_held = regularised || std::find(held.begin(), held.end(), true) != held.end();
  PatternSink pattern;
  for (int i = 0; i < N; ++i) pattern.Add(i, i, 0.0);
  AddSparse(system.mass, 1.0, &pattern);
  system.constraints.Jacobian(data.imposed, q, t, &pattern, n, 1.0);
  system.constraints.JacobianTranspose(data.imposed, q, t, &pattern, n, 1.0);
  m.A = pattern.Build(N, N);
  MatrixSink sink(&m.A);
  AddSparse(system.mass, 1.0, &sink);
  system.constraints.Jacobian(data.imposed, q, t, &sink, n, 1.0);
  system.constraints.JacobianTranspose(data.imposed, q, t, &sink, n, 1.0);
  system.constraints.AddReleasedDiagonal(t, &sink, n);
  system.constraints.AddComplianceDiagonal(&sink, n, 1.0);
  if (any_held) {
    for (int i = n; i < N; ++i) sink.Add(i, i, -kRedundancy);
  }
  // A point given a normal n: its three rows turned to [n, t₁, t₂]ᵀ (T A Tᵀ; the tie's compliance
  // c I and the 1e-10 on every row are unchanged by it), the two along the plane then left out,
  // so that only n · J q̇ is imposed. (A compliance of 1e6 on I − n nᵀ does the same in a matrix
  // whose other rows carry 1e-10, and its round-off reached 1e-8 of the impact's change on bodies
  // the impulse does not reach.)
  std::vector<size_t> turned;  // the points whose rows turn (their coupling rows in the matrix)
  for (size_t k = 0; normals != nullptr && k < normals->size(); ++k) {
    if (!(*normals)[k].isZero(0.0) && !m.out[static_cast<size_t>(n + system.interface_points[k].first_row)]) {
      turned.push_back(k);
    }
  }
  if (!turned.empty()) {
    std::vector<Eigen::Triplet<double>> turn;
    std::vector<bool> row_turned(static_cast<size_t>(mc), false);
    for (size_t k : turned) {
      const Eigen::Vector3d& nk = (*normals)[k];
      Eigen::Matrix3d frame;
      frame.row(0) = nk.transpose();
      const Eigen::Vector3d t1 = nk.unitOrthogonal();
      frame.row(1) = t1.transpose();
      frame.row(2) = nk.cross(t1).transpose();
      const int r = system.interface_points[k].first_row;
      for (int i = 0; i < 3; ++i) {
        row_turned[static_cast<size_t>(r + i)] = true;
        for (int j = 0; j < 3; ++j) turn.emplace_back(n + r + i, n + r + j, frame(i, j));
      }
      m.out[static_cast<size_t>(n + r + 1)] = m.out[static_cast<size_t>(n + r + 2)] = true;
    }
    for (int i = 0; i < n; ++i) turn.emplace_back(i, i, 1.0);
    for (int i = 0; i < mc; ++i) {
      if (!row_turned[static_cast<size_t>(i)]) turn.emplace_back(n + i, n + i, 1.0);
    }
    m.turn.resize(N, N);
    m.turn.setFromTriplets(turn.begin(), turn.end());
    m.A = Eigen::SparseMatrix<double>(m.turn * m.A * m.turn.transpose());
  }
  m.full = m.A;
  const std::vector<bool>& out = m.out;
  m.A.prune([&](Eigen::Index row, Eigen::Index col, double) {
    return !(out[static_cast<size_t>(row)] || out[static_cast<size_t>(col)]) || row == col;
  });
  for (int i = 0; i < N; ++i) {
    if (out[static_cast<size_t>(i)]) m.A.coeffRef(i, i) = 1.0;
  }
  return m;
}

// min ½ Δq̇ᵀ M Δq̇ over the rigid bodies' velocities, the elastic coordinates' held, subject to the
// constraints' velocity rows with the coupling rows of `points` only.
bool SmallestImpactChange(const MultibodySystem& system, const SystemData& data, double t,
                          const std::vector<bool>& held, const std::vector<int>& points, DaeState* state,
                          const ImpactNormals* normals) {
  const int n = system.coordinates, mc = system.constraints.size(), N = n + mc;
  ImpactMatrix m = BuildImpactMatrix(system, data, t, state->q, held, points, false, normals);
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(N);
  rhs.head(n) = system.mass * state->qdot;
  system.constraints.TimeDerivative(data.imposed, state->q, t, rhs.segment(n, mc));
  rhs.segment(n, mc) *= -1.0;
  rhs = m.Turned(rhs);
  // Held coordinates: their columns move to the right-hand side at their present rates, their
  // rows say q̇_j = its rate. A dropped row: its multiplier alone, μ = 0.
  Eigen::VectorXd fixed = Eigen::VectorXd::Zero(N);
  for (int j = 0; j < n; ++j) {
    if (held[static_cast<size_t>(j)]) fixed(j) = state->qdot(j);
  }
  rhs -= m.full * fixed;
  for (int i = 0; i < N; ++i) {
    if (m.out[static_cast<size_t>(i)]) rhs(i) = i < n ? state->qdot(i) : 0.0;
  }
  KluSolver lu;
  if (!FactorizeHubLast(&m.A, system.rigid_coordinates(), &lu)) return false;
  lu.SolveInPlace(rhs);
  state->qdot = rhs.head(n);
  return state->qdot.allFinite();
}

}  // namespace

std::vector<int> BodiesAnImpulseMoves(const MultibodySystem& system, const SystemData& data, double t,
                                      const Eigen::VectorXd& q, int point, Eigen::Matrix3d* mobility) {
  // [M Φ_qᵀ; Φ_q −C] [Δq̇; P] = [J_kᵀ e; 0] for the three directions e: the velocity change an
  // impulse at the point makes at once through the constraints, every coupling row left out (the
  // other nodes' ties give way within an impact; the point's own carries the impulse) and the
  // hex27 nodes held (their rows are point rows, not rigid joints). Beam nodes are bodies: the
  // impulse reaches a clamped root node through its rows and the rest of the beam through its
  // stiffness, which is not impulsive. Every row takes a compliance of 1e-10 (a closed pitch-link
  // loop's redundant rows; a driven hub then takes ~1e-10 of the energy).
  const int n = system.coordinates, N = n + system.constraints.size();
  const int bodies = system.rigid_coordinates() / kCoordinatesPerBody;
  ImpactMatrix m = BuildImpactMatrix(system, data, t, q, Hex27Coordinates(system), {}, /*regularised=*/true);
  KluSolver lu;
  if (!FactorizeHubLast(&m.A, system.rigid_coordinates(), &lu)) return {};
  Eigen::VectorXd energy = Eigen::VectorXd::Zero(bodies);
  const InterfacePoint& p = system.interface_points[static_cast<size_t>(point)];
  for (int d = 0; d < 3; ++d) {
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(N);
    for (const LinearVector::Term& term : p.point.terms) rhs(term.offset + d) += term.coefficient;
    lu.SolveInPlace(rhs);
    const Eigen::VectorXd dv = rhs.head(n);
    if (!dv.allFinite()) return {};
    if (mobility != nullptr) mobility->col(d) = p.point.Rate(dv);
    const Eigen::VectorXd m_dv = system.mass * dv;
    for (int b = 0; b < bodies; ++b) {
      const Eigen::Index o = static_cast<Eigen::Index>(kCoordinatesPerBody) * b;
      energy(b) += std::abs(dv.segment<kCoordinatesPerBody>(o).dot(m_dv.segment<kCoordinatesPerBody>(o)));
    }
  }
  std::vector<int> moved;
  const double total = energy.sum();
  for (int b = 0; b < bodies; ++b) {
    if (energy(b) > 1e-6 * total) moved.push_back(b);
  }
  return moved;
}

std::vector<int> ProjectImpactVelocities(const MultibodySystem& system, const SystemData& data, double t,
                                         const std::vector<int>& impacting, const ImpactNormals& normals,
                                         DaeState* state) {
  const std::vector<bool> held = ElasticCoordinates(system);
  std::vector<int> points = impacting;
  for (int pass = 0; pass < 2 && !points.empty(); ++pass) {
    DaeState trial = *state;
    if (!SmallestImpactChange(system, data, t, held, points, &trial, &normals)) return {};
    // A point whose node's velocity the rigid bodies could not take (its body clamped to a
    // beam, or joined to one: the jump would have to bend the beam within the step) is left to
    // its tie; the others are projected again without it.
    std::vector<int> taken;
    for (int k : points) {
      const InterfacePoint& p = system.interface_points[static_cast<size_t>(k)];
      Eigen::Vector3d wanted;
      for (int j = 0; j < 3; ++j) wanted(j) = data.imposed[static_cast<size_t>(3 * k + j)].rate;
      const Eigen::Vector3d& nk = normals[static_cast<size_t>(k)];
      const Eigen::Matrix3d across =
          nk.isZero(0.0) ? Eigen::Matrix3d::Identity() : Eigen::Matrix3d(nk * nk.transpose());
      const double jump = (across * (wanted - p.point.Rate(state->qdot))).norm();
      if ((across * (wanted - p.point.Rate(trial.qdot))).norm() <= 0.1 * jump + 1e-9) taken.push_back(k);
    }
    if (taken.size() == points.size()) {
      *state = trial;
      return points;
    }
    points = taken;
  }
  return {};
}

bool MoveImpactPointsOntoNodes(const MultibodySystem& system, const SystemData& data, double t,
                               const std::vector<int>& points, const ImpactNormals& normals, DaeState* state) {
  // The smallest move of the rigid bodies in the mass metric that puts each point on its node:
  // [M Φ_qᵀ; Φ_q −C] [Δq; μ] = [0; −Φ(q)] with the restart's rows (the elastic coordinates held,
  // the other points' coupling rows out), Newton on the matrix kept (Φ is quadratic in the
  // Euler parameters; the move is a fraction of a millimetre).
  const int n = system.coordinates, mc = system.constraints.size(), N = n + mc;
  const std::vector<bool> held = ElasticCoordinates(system);
  ImpactMatrix m = BuildImpactMatrix(system, data, t, state->q, held, points);
  KluSolver lu;
  if (!FactorizeHubLast(&m.A, system.rigid_coordinates(), &lu)) return false;
  DaeState moved = *state;
  Eigen::VectorXd rhs(N), phi(mc);
  for (int iteration = 0; iteration < 3; ++iteration) {
    system.constraints.Evaluate(data.imposed, moved.q, t, phi);
    rhs.setZero();
    rhs.segment(n, mc) = -phi;
    for (int i = 0; i < N; ++i) {
      if (m.out[static_cast<size_t>(i)]) rhs(i) = 0.0;
    }
    lu.SolveInPlace(rhs);
    const Eigen::VectorXd dq = rhs.head(n);
    if (!dq.allFinite()) return false;
    moved.q += dq;
  }
  // The velocities again at the new positions, whose Jacobians have moved with them (a body's
  // axes would otherwise no longer move rigidly).
  if (!SmallestImpactChange(system, data, t, held, points, &moved, &normals)) return false;
  *state = moved;
  return true;
}

void HoldClosedLocks(MultibodySystem* system, const SystemData& data, const Eigen::VectorXd& q, double t0) {
  ConstraintSet& cs = system->constraints;
  const ImposedValues& imposed = data.imposed;
  Eigen::VectorXd phi(cs.size());
  cs.Evaluate(imposed, q, t0, phi);
  for (int i = 0; i < cs.size(); ++i) {
    ScalarConstraint& c = cs.constraints[static_cast<size_t>(i)];
    if (c.set_by_closure) c.constant -= phi(i);  // Φ_i(q) = 0 from now on (its constant has weight 1)
  }
}

}  // namespace cosim::smooth
