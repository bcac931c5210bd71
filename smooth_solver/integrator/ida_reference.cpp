#include "smooth_solver/integrator/ida_reference.h"

#include "smooth_solver/integrator/cgalpha.h"

#include <ida/ida.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>

#include <cmath>

#include "interface/run/errors.h"
#include "smooth_solver/linear_algebra/dense_sink.h"
#include "smooth_solver/linear_algebra/fixed_pattern_matrix.h"

namespace cosim::smooth {

namespace {

Eigen::Map<Eigen::VectorXd> View(N_Vector v) {
  return Eigen::Map<Eigen::VectorXd>(N_VGetArrayPointer(v), N_VGetLength(v));
}

}  // namespace

struct IdaReference::Impl {
  const MultibodySystem* system = nullptr;
  int n = 0, m = 0;
  SUNContext ctx = nullptr;
  N_Vector y = nullptr, yp = nullptr, id = nullptr;
  SUNMatrix J = nullptr;
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
    p->system->constraints.AddJacobianTransposeTimes(q, t, mu, r.head(n));
    // M v̇ − f + Φ_qᵀ λ
    p->system->Force(q, v, t, p->force);
    r.segment(n, n) = p->system->mass * yp.segment(n, n) - p->force;
    p->system->constraints.AddJacobianTransposeTimes(q, t, lambda, r.segment(n, n));
    // Φ_q v + Φ_t
    p->system->constraints.JacobianTimes(q, t, v, r.segment(2 * n, m));
    p->system->constraints.TimeDerivative(q, t, p->scratch);
    r.segment(2 * n, m) += p->scratch;
    // Φ
    p->system->constraints.Evaluate(q, t, r.tail(m));
    // Released rows (a locked joint after its release): λ_i = Λ̇_i = 0, μ_i = Μ̇_i = 0.
    for (int i = 0; i < m; ++i) {
      if (!p->system->constraints.Active(static_cast<size_t>(i), t)) {
        r(2 * n + i) = yp(2 * n + i);
        r(2 * n + m + i) = yp(2 * n + m + i);
      }
    }
    return r.allFinite() ? 0 : 1;
  }

  // dF/dy + c_j dF/dẏ.
  static int Jacobian(realtype t, realtype cj, N_Vector yv, N_Vector ypv, N_Vector, SUNMatrix J, void* data, N_Vector,
                      N_Vector, N_Vector) {
    auto* p = static_cast<Impl*>(data);
    const int n = p->n, m = p->m;
    const auto y = View(yv), yp = View(ypv);
    const auto q = y.head(n), v = y.segment(n, n), lambda = yp.segment(2 * n, m), mu = yp.tail(m);
    SUNMatZero(J);
    SunDenseSink sink(J);
    const ConstraintSet& cs = p->system->constraints;
    for (int i = 0; i < n; ++i) {
      sink.Add(i, i, cj);          // ∂(q̇)/∂ẏ
      sink.Add(i, n + i, -1.0);    // −v
    }
    // Rows of q̇: Σ μ_i ∂²φ_i/∂q² and c_j Φ_qᵀ (Μ columns: μ = Μ̇).
    cs.HessianTimesLambda(t, mu, &sink, 1.0);
    cs.JacobianTranspose(q, t, &sink, 2 * n + m, cj);
    // Rows of v̇: Σ λ_i ∂²φ_i/∂q² (shifted to rows n..2n), c_j M, c_j Φ_qᵀ (Λ columns).
    class Shift : public SparseSink {
     public:
      Shift(SparseSink* inner, int row) : inner_(inner), row_(row) {}
      void Add(int r, int c, double value) override { inner_->Add(r + row_, c, value); }

     private:
      SparseSink* inner_;
      int row_;
    } shifted(&sink, n);
    cs.HessianTimesLambda(t, lambda, &shifted, 1.0);
    // −∂f/∂q in the q columns, −∂f/∂v in the v columns.
    p->system->AddForceTangent(q, v, t, 1.0, 0.0, &shifted);
    class BothShift : public SparseSink {
     public:
      BothShift(SparseSink* inner, int shift) : inner_(inner), shift_(shift) {}
      void Add(int r, int c, double value) override { inner_->Add(r + shift_, c + shift_, value); }

     private:
      SparseSink* inner_;
      int shift_;
    } v_block(&sink, n);
    p->system->AddForceTangent(q, v, t, 0.0, 1.0, &v_block);
    MatrixSinkAdd(p->system->mass, cj, n, n, &sink);
    cs.JacobianTranspose(q, t, &shifted, 2 * n, cj);
    // Velocity constraint rows: ∂(Φ_q v + Φ_t)/∂q and Φ_q (v columns).
    cs.VelocityConstraintJacobian(q, v, t, &sink, 2 * n);
    class ColumnShift : public SparseSink {
     public:
      ColumnShift(SparseSink* inner, int column) : inner_(inner), column_(column) {}
      void Add(int r, int c, double value) override { inner_->Add(r, c + column_, value); }

     private:
      SparseSink* inner_;
      int column_;
    } v_columns(&sink, n);
    cs.Jacobian(q, t, &v_columns, 2 * n, 1.0);
    // Position constraint rows: Φ_q.
    cs.Jacobian(q, t, &sink, 2 * n + m, 1.0);
    for (int i = 0; i < m; ++i) {
      if (!cs.Active(static_cast<size_t>(i), t)) {
        sink.Add(2 * n + i, 2 * n + i, cj);
        sink.Add(2 * n + m + i, 2 * n + m + i, cj);
      }
    }
    return 0;
  }

  static void MatrixSinkAdd(const Eigen::SparseMatrix<double>& a, double scale, int row, int column, SparseSink* sink) {
    for (int k = 0; k < a.outerSize(); ++k) {
      for (Eigen::SparseMatrix<double>::InnerIterator it(a, k); it; ++it) {
        sink->Add(row + static_cast<int>(it.row()), column + static_cast<int>(it.col()), scale * it.value());
      }
    }
  }
};

IdaReference::IdaReference(const MultibodySystem& system, const IdaSettings& settings, const DaeState& initial,
                           double t0)
    : impl_(std::make_unique<Impl>()), state_(initial) {
  Impl& p = *impl_;
  p.system = &system;
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
  p.J = SUNDenseMatrix(N, N, p.ctx);
  p.LS = SUNLinSol_Dense(p.y, p.J, p.ctx);
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
  double target = t + h;
  while (true) {
    const double release = p.system->constraints.NextRelease(reached, t + h);
    target = std::isfinite(release) ? release : t + h;
    IDASetStopTime(p.ida, target);
    const int flag = IDASolve(p.ida, target, &reached, p.y, p.yp, IDA_NORMAL);
    if (flag < 0) {
      throw NumericalError("IDA failed with flag " + std::to_string(flag) + " on its way to t = " +
                           std::to_string(target) + " s (reached " + std::to_string(reached) + " s)");
    }
    if (!std::isfinite(release) || reached >= t + h) break;
    IDAGetNumSteps(p.ida, &after);
    total += after - before;
    // Consistent v̇ and λ for the equations just after the release.
    DaeState after_release;
    after_release.q = View(p.y).head(p.n);
    after_release.qdot = View(p.y).segment(p.n, p.n);
    ConsistentAccelerations(*p.system, std::nextafter(reached, INFINITY), &after_release);
    View(p.yp).segment(p.n, p.n) = after_release.qddot;
    View(p.yp).segment(2 * p.n, p.m) = after_release.lambda;
    View(p.yp).tail(p.m).setZero();
    IDAReInit(p.ida, reached, p.y, p.yp);
    IDAGetNumSteps(p.ida, &before);
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
  impl_->system->constraints.Evaluate(state_.q, t, phi);
  return phi.size() > 0 ? phi.lpNorm<Eigen::Infinity>() : 0.0;
}

long IdaReference::internal_steps() const {
  long steps = 0;
  IDAGetNumSteps(impl_->ida, &steps);
  return steps;
}

}  // namespace cosim::smooth
