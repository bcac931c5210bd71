#include "nonsmooth_solver/lcp/lcp_solver.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <vector>

extern "C" {
#include "LCP_Solvers.h"
#include "LinearComplementarityProblem.h"
#include "NonSmoothDrivers.h"
#include "NumericsMatrix.h"
#include "SolverOptions.h"
#include "lcp_cst.h"
}

#include "interface/scenario/checks.h"
#include "nonsmooth_solver/lcp/siconos_options.h"

namespace cosim::nonsmooth {

const char* LcpAlgorithmName(LcpAlgorithm algorithm) {
  switch (algorithm) {
    case LcpAlgorithm::kLemke:
      return "LEMKE";
    case LcpAlgorithm::kPgs:
      return "PGS";
    case LcpAlgorithm::kEnumerative:
      return "ENUMERATIVE";
    case LcpAlgorithm::kNewtonFischerBurmeister:
      return "NEWTON_FB";
  }
  return "?";
}

namespace {

int SiconosSolverId(LcpAlgorithm algorithm) {
  switch (algorithm) {
    case LcpAlgorithm::kLemke:
      return SICONOS_LCP_LEMKE;
    case LcpAlgorithm::kPgs:
      return SICONOS_LCP_PGS;
    case LcpAlgorithm::kEnumerative:
      return SICONOS_LCP_ENUM;
    case LcpAlgorithm::kNewtonFischerBurmeister:
      return SICONOS_LCP_NEWTON_FB_FBLSA;
  }
  return SICONOS_LCP_LEMKE;
}

}  // namespace

double ComplementarityError(const Eigen::Ref<const Eigen::MatrixXd>& M, const Eigen::Ref<const Eigen::VectorXd>& q,
                            const Eigen::Ref<const Eigen::VectorXd>& z) {
  double error = 0.0;
  const Eigen::Index n = q.size();
  for (Eigen::Index i = 0; i < n; ++i) {
    const double wi = M.row(i).dot(z) + q(i);
    const double zi = z(i);
    error = std::max({error, -zi, -wi, std::abs(std::min(zi, wi))});
  }
  if (!std::isfinite(error)) return std::numeric_limits<double>::infinity();
  return error / (1.0 + q.lpNorm<Eigen::Infinity>());
}

LcpSolver::LcpSolver(const LcpOptions& options) : options_(options) {}
LcpSolver::~LcpSolver() = default;

LcpResult LcpSolver::Solve(const Eigen::Ref<const Eigen::MatrixXd>& M, const Eigen::Ref<const Eigen::VectorXd>& q,
                           Eigen::Ref<Eigen::VectorXd> z) {
  const Eigen::Index n = q.size();
  if (n == 0) return LcpResult{true, false, true, 0, 0, 0.0, ""};
  // q >= 0: z = 0 gives w = q >= 0, complementary. Exact, and the driver would do the same.
  if (q.minCoeff() >= 0.0) {
    z.setZero();
    return LcpResult{true, false, true, 0, 0, 0.0, ""};
  }
  LcpResult result = Attempt(options_.algorithm, M, q, z);
  std::string messages = result.message;
  double best_error = result.error;
  best_ = z;
  for (LcpAlgorithm fallback : options_.fallbacks) {
    if (result.solved) break;
    if (fallback == options_.algorithm) continue;
    result = Attempt(fallback, M, q, z);
    if (result.solved) {
      result.used_fallback = true;
    } else {
      messages += "; fallback " + result.message;
      if (result.error < best_error) {
        best_error = result.error;
        best_ = z;
      }
    }
  }
  // The last resorts, only where fallbacks are wanted at all (fallback [NONE] keeps a failure).
  if (!result.solved && !options_.fallbacks.empty() && std::isfinite(best_error)) {
    z = best_;
    const double error = PolishActiveSet(M, q, z);
    if (error <= Accepted()) {
      result.solved = true;
      result.used_fallback = true;
      result.error = error;
      result.message.clear();
      return result;
    }
    messages += "; the closest (error " + interface::FormatNumber(best_error) +
                ") polished on its active set: " + interface::FormatNumber(error);
    if (SolveBlockByBlock(M, q, z, &result)) return result;
  }
  if (!result.solved) result.message = messages;
  return result;
}

bool LcpSolver::SolveBlockByBlock(const Eigen::Ref<const Eigen::MatrixXd>& M,
                                  const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<Eigen::VectorXd> z,
                                  LcpResult* result) {
  const Eigen::Index n = q.size();
  // Connected components of the graph i ~ j where M_ij or M_ji is non-zero (union–find).
  std::vector<Eigen::Index> parent(static_cast<size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) parent[static_cast<size_t>(i)] = i;
  auto root = [&](Eigen::Index i) {
    while (parent[static_cast<size_t>(i)] != i)
      i = parent[static_cast<size_t>(i)] = parent[static_cast<size_t>(parent[static_cast<size_t>(i)])];
    return i;
  };
  for (Eigen::Index j = 0; j < n; ++j) {
    for (Eigen::Index i = 0; i < n; ++i) {
      if (i != j && (M(i, j) != 0.0 || M(j, i) != 0.0)) parent[static_cast<size_t>(root(i))] = root(j);
    }
  }
  std::vector<std::vector<Eigen::Index>> blocks;
  std::vector<Eigen::Index> block_of(static_cast<size_t>(n), -1);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Index r = root(i);
    if (block_of[static_cast<size_t>(r)] < 0) {
      block_of[static_cast<size_t>(r)] = static_cast<Eigen::Index>(blocks.size());
      blocks.emplace_back();
    }
    blocks[static_cast<size_t>(block_of[static_cast<size_t>(r)])].push_back(i);
  }
  if (blocks.size() < 2) return false;
  Eigen::VectorXd solution = Eigen::VectorXd::Zero(n);
  for (const std::vector<Eigen::Index>& block : blocks) {
    const Eigen::Index m = static_cast<Eigen::Index>(block.size());
    Eigen::MatrixXd Mb(m, m);
    Eigen::VectorXd qb(m), zb(m);
    for (Eigen::Index a = 0; a < m; ++a) {
      qb(a) = q(block[static_cast<size_t>(a)]);
      for (Eigen::Index b = 0; b < m; ++b) Mb(a, b) = M(block[static_cast<size_t>(a)], block[static_cast<size_t>(b)]);
    }
    const LcpResult part = Solve(Mb, qb, zb);
    if (!part.solved) return false;
    for (Eigen::Index a = 0; a < m; ++a) solution(block[static_cast<size_t>(a)]) = zb(a);
  }
  const double error = ComplementarityError(M, q, solution);
  if (!(error <= Accepted())) return false;
  z = solution;
  result->solved = true;
  result->used_fallback = true;
  result->error = error;
  result->message.clear();
  return true;
}

double LcpSolver::PolishActiveSet(const Eigen::Ref<const Eigen::MatrixXd>& M,
                                  const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<Eigen::VectorXd> z) const {
  const Eigen::Index n = q.size();
  double error = ComplementarityError(M, q, z);
  Eigen::VectorXd trial = z;
  std::vector<std::vector<Eigen::Index>> seen;  // the sets tried: a repeat ends the passes
  for (int pass = 0; pass < 30; ++pass) {
    const Eigen::VectorXd w = M * trial + q;
    std::vector<Eigen::Index> active;
    for (Eigen::Index i = 0; i < n; ++i) {
      if (trial(i) > w(i)) active.push_back(i);
    }
    if (std::find(seen.begin(), seen.end(), active) != seen.end()) break;
    seen.push_back(active);
    const Eigen::Index m = static_cast<Eigen::Index>(active.size());
    Eigen::MatrixXd block(m, m);
    Eigen::VectorXd rhs(m);
    for (Eigen::Index a = 0; a < m; ++a) {
      rhs(a) = -q(active[static_cast<size_t>(a)]);
      for (Eigen::Index b = 0; b < m; ++b)
        block(a, b) = M(active[static_cast<size_t>(a)], active[static_cast<size_t>(b)]);
    }
    const Eigen::VectorXd zb = block.completeOrthogonalDecomposition().solve(rhs);
    trial.setZero();
    for (Eigen::Index a = 0; a < m; ++a) trial(active[static_cast<size_t>(a)]) = zb(a);
    const double trial_error = ComplementarityError(M, q, trial);
    if (trial_error < error) {  // the primal-dual active-set passes need not descend: keep the best
      error = trial_error;
      z = trial;
    }
  }
  return error;
}

LcpResult LcpSolver::Attempt(LcpAlgorithm algorithm, const Eigen::Ref<const Eigen::MatrixXd>& M,
                             const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<Eigen::VectorXd> z) {
  LcpResult result;
  result.error = std::numeric_limits<double>::infinity();  // until an attempt is made and checked
  const int n = static_cast<int>(q.size());
  if (algorithm == LcpAlgorithm::kEnumerative && n > kMaxEnumerativeSize) {
    result.message = std::string("ENUMERATIVE refused: n = ") + std::to_string(n) + " > " +
                     std::to_string(kMaxEnumerativeSize) + " (2^n cases)";
    return result;
  }
  if (!M.allFinite() || !q.allFinite()) {
    result.message = "LCP data not finite";
    return result;
  }
  // Extreme data (|q| or |M| beyond 2^±40: a node at 1e20 m/s) crash Siconos' Lemke (SIGSEGV
  // found by fuzzing). The LCP is invariant under positive scaling: with M = a M', q = b q' it
  // is solved as LCP(M', q') for z' = (a / b) z. Powers of two keep every other digit exact, and
  // data in the ordinary range is passed untouched.
  auto power_of_two = [](double norm) {
    return norm > 0.0 && (norm > 0x1p40 || norm < 0x1p-40) ? std::ldexp(1.0, std::ilogb(norm)) : 1.0;
  };
  const double a = power_of_two(M.lpNorm<Eigen::Infinity>());
  const double b = power_of_two(q.lpNorm<Eigen::Infinity>());
  // Siconos takes ownership of M's storage and q (freed by freeLinearComplementarityProblem).
  NumericsMatrix* matrix = NM_create(NM_DENSE, n, n);
  // Column-major copy that respects M's outer stride (M is often a corner of a larger workspace).
  Eigen::Map<Eigen::MatrixXd>(matrix->matrix0, n, n) = M / a;
  LinearComplementarityProblem* lcp = newLCP();
  lcp->size = n;
  lcp->M = matrix;
  lcp->q = static_cast<double*>(std::malloc(sizeof(double) * static_cast<size_t>(n)));
  Eigen::Map<Eigen::VectorXd>(lcp->q, n) = q / b;
  // The enumerative solver caches work arrays sized by the first problem in its options:
  // a fresh options object per attempt keeps that safe for every algorithm.
  SolverOptions* so = solver_options_create(SiconosSolverId(algorithm));
  so->iparam[SICONOS_IPARAM_MAX_ITER] = options_.max_iterations;
  so->dparam[SICONOS_DPARAM_TOL] = options_.tolerance;
  w_.resize(n);
  z.setZero();
  result.siconos_info = linearComplementarity_driver(lcp, z.data(), w_.data(), so);
  z *= b / a;
  result.iterations = so->iparam[SICONOS_IPARAM_ITER_DONE];
  FreeSolverOptions(so);
  freeLinearComplementarityProblem(lcp);

  // Our own check, whatever the driver said.
  result.error = ComplementarityError(M, q, z);
  // The tolerance applies to the complementarity error; a few ulps of slack on top of it.
  result.solved = result.error <= Accepted();
  if (!result.solved) {
    result.message = std::string(LcpAlgorithmName(algorithm)) + " (n = " + std::to_string(n) + ", Siconos info " +
                     std::to_string(result.siconos_info) + ", " + std::to_string(result.iterations) +
                     " iterations): complementarity error " + interface::FormatNumber(result.error) + " > tolerance " +
                     interface::FormatNumber(options_.tolerance);
  }
  return result;
}

bool ReadSiconosLcpFile(const std::string& path, Eigen::MatrixXd* M, Eigen::VectorXd* q) {
  // Siconos' reader exit()s on a missing file and returns 1 on success: check first, then
  // judge by what it filled in.
  if (std::FILE* f = std::fopen(path.c_str(), "r")) {
    std::fclose(f);
  } else {
    return false;
  }
  LinearComplementarityProblem* lcp = newLCP();
  lcp->M = nullptr;
  lcp->q = nullptr;
  linearComplementarity_newFromFilename(lcp, path.c_str());
  if (lcp->M == nullptr || lcp->q == nullptr || lcp->size <= 0 || lcp->M->size0 != lcp->size) {
    freeLinearComplementarityProblem(lcp);
    return false;
  }
  const int n = lcp->size;
  M->resize(n, n);
  q->resize(n);
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) (*M)(i, j) = NM_get_value(lcp->M, i, j);
    (*q)(j) = lcp->q[j];
  }
  freeLinearComplementarityProblem(lcp);
  return true;
}

}  // namespace cosim::nonsmooth
