#include "nonsmooth_solver/lcp/friction_contact_solver.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>

extern "C" {
#include "FrictionContactProblem.h"
#include "Friction_cst.h"
#include "NonSmoothDrivers.h"
#include "NumericsMatrix.h"
#include "SolverOptions.h"
}

#include "interface/scenario/checks.h"
#include "nonsmooth_solver/lcp/siconos_options.h"

namespace cosim::nonsmooth {

namespace {

// Projection of (n, t1, t2) onto the cone {|t| <= μ n}.
Eigen::Vector3d ProjectOnCone(const Eigen::Vector3d& x, double mu) {
  const double n = x(0);
  const double t = x.tail<2>().norm();
  if (t <= mu * n) return x;                         // inside
  if (mu * t <= -n) return Eigen::Vector3d::Zero();  // inside the polar cone
  const double a = (n + mu * t) / (1.0 + mu * mu);
  Eigen::Vector3d p;
  p(0) = a;
  p.tail<2>() = t > 0.0 ? Eigen::Vector2d(mu * a * x.tail<2>() / t) : Eigen::Vector2d::Zero();
  return p;
}

}  // namespace

double FrictionContactError(const Eigen::Ref<const Eigen::MatrixXd>& W, const Eigen::Ref<const Eigen::VectorXd>& q,
                            const Eigen::Ref<const Eigen::VectorXd>& mu, const Eigen::Ref<const Eigen::VectorXd>& r) {
  const Eigen::VectorXd u = W * r + q;
  double error = 0.0;
  for (Eigen::Index c = 0; c < mu.size(); ++c) {
    const Eigen::Vector3d rc = r.segment<3>(3 * c);
    Eigen::Vector3d uhat = u.segment<3>(3 * c);
    uhat(0) += mu(c) * uhat.tail<2>().norm();
    error = std::max(error, (rc - ProjectOnCone(rc - uhat, mu(c))).lpNorm<Eigen::Infinity>());
  }
  if (!std::isfinite(error)) return std::numeric_limits<double>::infinity();
  return error / (1.0 + q.lpNorm<Eigen::Infinity>());
}

FrictionContactResult SolveFrictionContact(const Eigen::Ref<const Eigen::MatrixXd>& W,
                                           const Eigen::Ref<const Eigen::VectorXd>& q,
                                           const Eigen::Ref<const Eigen::VectorXd>& mu, double tolerance,
                                           int max_iterations, Eigen::Ref<Eigen::VectorXd> r) {
  FrictionContactResult result;
  const int n = static_cast<int>(q.size());
  const int nc = static_cast<int>(mu.size());
  r.setZero();
  if (!W.allFinite() || !q.allFinite()) {
    result.message = "friction-contact data not finite";
    return result;
  }
  // Siconos owns (and frees) the matrix storage, q and mu.
  NumericsMatrix* matrix = NM_create(NM_DENSE, n, n);
  Eigen::Map<Eigen::MatrixXd>(matrix->matrix0, n, n) = W;
  auto* q_copy = static_cast<double*>(std::malloc(sizeof(double) * static_cast<size_t>(n)));
  auto* mu_copy = static_cast<double*>(std::malloc(sizeof(double) * static_cast<size_t>(nc)));
  std::memcpy(q_copy, q.data(), sizeof(double) * static_cast<size_t>(n));
  std::memcpy(mu_copy, mu.data(), sizeof(double) * static_cast<size_t>(nc));
  FrictionContactProblem* problem = frictionContactProblem_new_with_data(3, nc, matrix, q_copy, mu_copy);
  SolverOptions* options = solver_options_create(SICONOS_FRICTION_3D_NSGS);
  options->iparam[SICONOS_IPARAM_MAX_ITER] = max_iterations;
  options->dparam[SICONOS_DPARAM_TOL] = tolerance;
  Eigen::VectorXd u(n);
  result.siconos_info = fc3d_driver(problem, r.data(), u.data(), options);
  result.iterations = options->iparam[SICONOS_IPARAM_ITER_DONE];
  FreeSolverOptions(options);
  frictionContactProblem_free(problem);

  result.error = FrictionContactError(W, q, mu, r);
  result.solved = result.error <= std::max(tolerance, 64.0 * std::numeric_limits<double>::epsilon());
  if (!result.solved) {
    result.message = "Siconos fc3d NSGS (" + std::to_string(nc) + " contacts, info " +
                     std::to_string(result.siconos_info) + ", " + std::to_string(result.iterations) +
                     " iterations): friction-contact error " + interface::FormatNumber(result.error) + " > tolerance " +
                     interface::FormatNumber(tolerance);
  }
  return result;
}

}  // namespace cosim::nonsmooth
