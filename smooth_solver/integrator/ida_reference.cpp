#include "smooth_solver/integrator/ida_reference.h"

#include <ida/ida.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sunlinsol/sunlinsol_klu.h>
#include <sunmatrix/sunmatrix_sparse.h>

#include <cmath>
#include <limits>

#include "interface/base/errors.h"
#include "interface/scenario/checks.h"
#include "smooth_solver/integrator/cgalpha.h"
#include "smooth_solver/linear_algebra/fixed_pattern_matrix.h"
#include "smooth_solver/linear_algebra/sun_sparse.h"

namespace cosim::smooth {

namespace {

Eigen::Map<Eigen::VectorXd> View(N_Vector v) {
  return Eigen::Map<Eigen::VectorXd>(N_VGetArrayPointer(v), N_VGetLength(v));
}

}  // namespace

struct IdaReference::Impl {
  const MultibodySystem* system = nullptr;
  const SystemData* data = nullptr;  // the run's changing state
  int n = 0, m = 0;
  SUNContext ctx = nullptr;
  N_Vector y = nullptr, yp = nullptr, id = nullptr;
  SUNMatrix J = nullptr;
  Eigen::SparseMatrix<double> A;  // the Jacobian, pattern fixed at construction
  SUNLinearSolver LS = nullptr;
  void* ida = nullptr;
  Eigen::VectorXd scratch, force;

  // F(t, y, ẏ), y = [q, v, Λ, Μ], ẏ = [q̇, v̇, λ, μ].
  static int Residual(realtype t, N_Vector yv, N_Vector ypv, N_Vector rv, void* data) {
    auto* p = static_cast<Impl*>(data);
    const int n = p->n, m = p->m;
    const auto y = View(yv), yp = View(ypv);
    auto r = View(rv);
    const auto q = y.head(n), v = y.segment(n, n), lambda = yp.segment(2 * n, m), mu = yp.tail(m);
    // q̇ − v + Φ_qᵀ μ
    r.head(n) = yp.head(n) - v;
    p->system->constraints.AddJacobianTransposeTimes(p->data->imposed, q, t, mu, r.head(n));
    // M v̇ − f + Φ_qᵀ λ
    p->system->Force(q, v, t, *p->data, p->force);
    r.segment(n, n) = p->system->mass * yp.segment(n, n) - p->force;
    p->system->constraints.AddJacobianTransposeTimes(p->data->imposed, q, t, lambda, r.segment(n, n));
    // Φ_q v + Φ_t
    p->system->constraints.JacobianTimes(p->data->imposed, q, t, v, r.segment(2 * n, m));
    p->system->constraints.TimeDerivative(p->data->imposed, q, t, p->scratch);
    r.segment(2 * n, m) += p->scratch;
    // Φ
    p->system->constraints.Evaluate(p->data->imposed, q, t, r.tail(m));
    // Released rows (a locked joint after its release): λ_i = Λ̇_i = 0, μ_i = Μ̇_i = 0.
    for (int i = 0; i < m; ++i) {
      if (!p->system->constraints.Active(static_cast<size_t>(i), t)) {
        r(2 * n + i) = yp(2 * n + i);
        r(2 * n + m + i) = yp(2 * n + m + i);
      }
    }
    return r.allFinite() ? 0 : 1;
  }

  // dF/dy + c_j dF/dẏ into `sink` (every entry lies in the pattern of BuildPattern).
  static void Fill(const Impl& p, double t, double cj, const Eigen::Ref<const Eigen::VectorXd>& y,
                   const Eigen::Ref<const Eigen::VectorXd>& yp, SparseSink* sink) {
    const int n = p.n, m = p.m;
    const Eigen::VectorXd q = y.head(n), v = y.segment(n, n), lambda = yp.segment(2 * n, m), mu = yp.tail(m);
    const ConstraintSet& cs = p.system->constraints;
    const ImposedValues& imposed = p.data->imposed;
    OffsetSink v_rows(sink, n, 0), v_block(sink, n, n), v_columns(sink, 0, n);
    for (int i = 0; i < n; ++i) {
      sink->Add(i, i, cj);        // ∂(q̇)/∂ẏ
      sink->Add(i, n + i, -1.0);  // −v
    }
    // Rows of q̇: Σ μ_i ∂²φ_i/∂q² and c_j Φ_qᵀ (Μ columns: μ = Μ̇).
    cs.HessianTimesLambda(imposed, t, mu, sink, 1.0);
    cs.JacobianTranspose(imposed, q, t, sink, 2 * n + m, cj);
    // Rows of v̇: Σ λ_i ∂²φ_i/∂q², −∂f/∂q (q columns), c_j M − ∂f/∂v (v columns), c_j Φ_qᵀ (Λ).
    cs.HessianTimesLambda(imposed, t, lambda, &v_rows, 1.0);
    p.system->AddForceTangent(q, v, t, *p.data, 1.0, 0.0, &v_rows);
    p.system->AddForceTangent(q, v, t, *p.data, 0.0, 1.0, &v_block);
    AddSparse(p.system->mass, cj, &v_block);
    cs.JacobianTranspose(imposed, q, t, &v_rows, 2 * n, cj);
    // Velocity constraint rows: ∂(Φ_q v + Φ_t)/∂q and Φ_q (v columns).
    cs.VelocityConstraintJacobian(imposed, q, v, t, sink, 2 * n);
    cs.Jacobian(imposed, q, t, &v_columns, 2 * n, 1.0);
    // Position constraint rows: Φ_q.
    cs.Jacobian(imposed, q, t, sink, 2 * n + m, 1.0);
    for (int i = 0; i < m; ++i) {
      if (!cs.Active(static_cast<size_t>(i), t)) {
        sink->Add(2 * n + i, 2 * n + i, cj);
        sink->Add(2 * n + m + i, 2 * n + m + i, cj);
      }
    }
  }

  // Every entry Fill may touch, whatever the state, time and multipliers.
  static Eigen::SparseMatrix<double> BuildPattern(const Impl& p) {
    const int n = p.n, m = p.m, N = 2 * n + 2 * m;
    const double always = -std::numeric_limits<double>::infinity();
    const ConstraintSet& cs = p.system->constraints;
    const ImposedValues& imposed = p.data->imposed;
    PatternSink pattern;
    OffsetSink v_rows(&pattern, n, 0), v_block(&pattern, n, n), v_columns(&pattern, 0, n);
    for (int i = 0; i < N; ++i) pattern.Add(i, i, 0.0);
    for (int i = 0; i < n; ++i) pattern.Add(i, n + i, 0.0);
    cs.HessianPattern(&pattern);
    cs.JacobianTranspose(imposed, p.system->q0, always, &pattern, 2 * n + m, 1.0);
    cs.HessianPattern(&v_rows);
    p.system->ForcePattern(&v_rows);
    p.system->ForcePattern(&v_block);
    AddSparse(p.system->mass, 1.0, &v_block);
    cs.JacobianTranspose(imposed, p.system->q0, always, &v_rows, 2 * n, 1.0);
    cs.Jacobian(imposed, p.system->q0, always, &pattern, 2 * n, 1.0);  // the velocity rows' q-pattern is Φ_q's
    cs.Jacobian(imposed, p.system->q0, always, &v_columns, 2 * n, 1.0);
    cs.Jacobian(imposed, p.system->q0, always, &pattern, 2 * n + m, 1.0);
    return pattern.Build(N, N);
  }

  static int Jacobian(realtype t, realtype cj, N_Vector yv, N_Vector ypv, N_Vector, SUNMatrix J, void* data, N_Vector,
                      N_Vector, N_Vector) {
    auto* p = static_cast<Impl*>(data);
    for (Eigen::Index k = 0; k < p->A.nonZeros(); ++k) p->A.valuePtr()[k] = 0.0;
    MatrixSink sink(&p->A);
    const Eigen::Index pattern_size = p->A.nonZeros();
    Fill(*p, t, cj, View(yv), View(ypv), &sink);
    COSIM_ASSERT(p->A.isCompressed() && p->A.nonZeros() == pattern_size, "IDA Jacobian left its pattern");
    CopyToSunSparse(p->A, J);  // IDA's compressed-sparse-column matrix, the same pattern every time
    return 0;
  }
};

IdaReference::IdaReference(const MultibodySystem& system, const SystemData& data, const IdaSettings& settings,
                           const DaeState& initial, double t0)
    : impl_(std::make_unique<Impl>()), state_(initial) {
  Impl& p = *impl_;
  p.system = &system;
  p.data = &data;
  p.n = system.coordinates;
  p.m = system.constraints.size();
  const int N = 2 * p.n + 2 * p.m;
  p.scratch.resize(p.m);
  p.force.resize(p.n);
  SUNContext_Create(nullptr, &p.ctx);
  p.y = N_VNew_Serial(N, p.ctx);
  p.yp = N_VNew_Serial(N, p.ctx);
  p.id = N_VNew_Serial(N, p.ctx);
  auto y = View(p.y), yp = View(p.yp), id = View(p.id);
  y << initial.q, initial.qdot, Eigen::VectorXd::Zero(2 * p.m);
  yp << initial.qdot, initial.qddot, initial.lambda, Eigen::VectorXd::Zero(p.m);
  id << Eigen::VectorXd::Ones(2 * p.n), Eigen::VectorXd::Zero(2 * p.m);
  p.A = Impl::BuildPattern(p);
  p.J = SUNSparseMatrix(N, N, p.A.nonZeros(), CSC_MAT, p.ctx);
  p.LS = SUNLinSol_KLU(p.y, p.J, p.ctx);
  p.ida = IDACreate(p.ctx);
  IDAInit(p.ida, Impl::Residual, t0, p.y, p.yp);
  IDASetUserData(p.ida, &p);
  IDASStolerances(p.ida, settings.relative_tolerance, settings.absolute_tolerance);
  IDASetLinearSolver(p.ida, p.LS, p.J);
  IDASetJacFn(p.ida, Impl::Jacobian);
  IDASetId(p.ida, p.id);
  IDASetSuppressAlg(p.ida, SUNTRUE);  // Λ, Μ out of the error test
  IDASetMaxNumSteps(p.ida, settings.max_steps_per_output);
}

IdaReference::~IdaReference() {
  Impl& p = *impl_;
  IDAFree(&p.ida);
  SUNLinSolFree(p.LS);
  SUNMatDestroy(p.J);
  N_VDestroy(p.y);
  N_VDestroy(p.yp);
  N_VDestroy(p.id);
  SUNContext_Free(&p.ctx);
}

int IdaReference::Step(double t, double h) {
  Impl& p = *impl_;
  long before = 0, after = 0, total = 0;
  IDAGetNumSteps(p.ida, &before);
  realtype reached = t;
  // A joint released within the step changes the equations: integrate up to the release,
  // restart IDA there (its multistep history belongs to the old equations), and go on.
  while (true) {
    const double release = p.system->constraints.NextRelease(reached, t + h);
    const double target = std::isfinite(release) ? release : t + h;
    IDASetStopTime(p.ida, target);
    const int flag = IDASolve(p.ida, target, &reached, p.y, p.yp, IDA_NORMAL);
    if (flag < 0) {
      throw NumericalError("IDA failed with flag " + std::to_string(flag) + " on its way to t = " +
                           interface::FormatNumber(target) + " s (reached " + interface::FormatNumber(reached) + " s)");
    }
    if (!std::isfinite(release)) break;
    // At the release time (possibly the end of this step): restart with the new equations.
    IDAGetNumSteps(p.ida, &after);
    total += after - before;
    // Consistent v̇ and λ for the equations just after the release.
    DaeState after_release;
    after_release.q = View(p.y).head(p.n);
    after_release.qdot = View(p.y).segment(p.n, p.n);
    ConsistentAccelerations(*p.system, *p.data, std::nextafter(reached, INFINITY), &after_release);
    View(p.yp).segment(p.n, p.n) = after_release.qddot;
    View(p.yp).segment(2 * p.n, p.m) = after_release.lambda;
    View(p.yp).tail(p.m).setZero();
    // Restart an ulp after the release, so that IDA never evaluates the new equations at the
    // release time itself, where the lock still holds (it holds up to its release time).
    reached = std::nextafter(reached, INFINITY);
    IDAReInit(p.ida, reached, p.y, p.yp);
    // The released rows change which entries are zero: KLU must choose new pivots.
    SUNLinSol_KLUReInit(p.LS, p.J, p.A.nonZeros(), SUNKLU_REINIT_PARTIAL);
    IDAGetNumSteps(p.ida, &before);
    if (reached >= t + h) break;
  }
  IDAGetNumSteps(p.ida, &after);
  total += after - before;
  const auto y = View(p.y), yp = View(p.yp);
  state_.q = y.head(p.n);
  state_.qdot = y.segment(p.n, p.n);
  state_.qddot = yp.segment(p.n, p.n);
  state_.lambda = yp.segment(2 * p.n, p.m);
  return static_cast<int>(total);
}

double IdaReference::ConstraintViolation(double t) const {
  Eigen::VectorXd phi(impl_->m);
  impl_->system->constraints.Evaluate(impl_->data->imposed, state_.q, t, phi);
  return phi.size() > 0 ? phi.lpNorm<Eigen::Infinity>() : 0.0;
}

long IdaReference::internal_steps() const {
  long steps = 0;
  IDAGetNumSteps(impl_->ida, &steps);
  return steps;
}

}  // namespace cosim::smooth
