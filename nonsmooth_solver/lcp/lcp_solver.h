#pragma once
// Linear complementarity problems  w = M z + q,  0 <= z ⟂ w >= 0  solved through Siconos
// Numerics' LCP driver. This is the only place that includes Siconos headers (they define
// generic macros). Every solution is checked here, independently of what Siconos reports:
// a lexicographic Lemke run can end on a secondary ray and still report success.
#include <Eigen/Core>
#include <algorithm>
#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace cosim::nonsmooth {

enum class LcpAlgorithm { kLemke, kPgs, kEnumerative, kNewtonFischerBurmeister };
const char* LcpAlgorithmName(LcpAlgorithm algorithm);

struct LcpOptions {
  LcpAlgorithm algorithm = LcpAlgorithm::kLemke;
  // Accepted complementarity error (see ComplementarityError), relative to 1 + |q|∞.
  double tolerance = 1e-10;
  int max_iterations = 10000;
  // Tried in order when `algorithm` fails the check.
  std::vector<LcpAlgorithm> fallbacks;
};

// The largest enumerative problem attempted: 2^n cases.
inline constexpr int kMaxEnumerativeSize = 12;

struct LcpResult {
  bool solved = false;         // passed the complementarity check
  bool used_fallback = false;  // the primary algorithm failed, a fallback succeeded
  bool trivial = false;        // q >= 0, z = 0 without calling Siconos
  int siconos_info = 0;        // driver return code of the last attempt (0 = success)
  int iterations = 0;          // of the last attempt
  double error = 0.0;          // complementarity error of the returned z
  std::string message;         // why it failed
};

// max_i max(−z_i, −w_i, |min(z_i, w_i)|) / (1 + |q|∞), with w = M z + q recomputed: zero
// exactly at a solution, and of the size of the violation otherwise.
double ComplementarityError(const Eigen::Ref<const Eigen::MatrixXd>& M, const Eigen::Ref<const Eigen::VectorXd>& q,
                            const Eigen::Ref<const Eigen::VectorXd>& z);

class LcpSolver {
 public:
  explicit LcpSolver(const LcpOptions& options);
  ~LcpSolver();
  LcpSolver(const LcpSolver&) = delete;
  LcpSolver& operator=(const LcpSolver&) = delete;

  const LcpOptions& options() const { return options_; }

  // Solves for z (size n, overwritten) given M (n×n) and q (n). On failure z holds the
  // last attempt and result.solved is false.
  LcpResult Solve(const Eigen::Ref<const Eigen::MatrixXd>& M, const Eigen::Ref<const Eigen::VectorXd>& q,
                  Eigen::Ref<Eigen::VectorXd> z);

 private:
  LcpResult Attempt(LcpAlgorithm algorithm, const Eigen::Ref<const Eigen::MatrixXd>& M,
                    const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<Eigen::VectorXd> z);
  // The last resort after every algorithm failed (with fallbacks configured): from the closest
  // candidate z, the active set
  // B = {i : z_i > w_i} solved exactly, M_BB z_B = −q_B (least squares where M_BB is singular,
  // as at a degenerate contact), z_N = 0, the set updated from the new z a few times. Returns
  // the complementarity error reached (z overwritten only if it improved).
  // Another last resort: an LCP whose M is block diagonal under some permutation (contacts that
  // do not interact, e.g. of nodes without springs between them, solved as one LCP) solved block
  // by block with the whole chain, so that each small block can fall back to ENUMERATIVE.
  // False if M is one block or a block fails.
  bool SolveBlockByBlock(const Eigen::Ref<const Eigen::MatrixXd>& M, const Eigen::Ref<const Eigen::VectorXd>& q,
                         Eigen::Ref<Eigen::VectorXd> z, LcpResult* result);
  double PolishActiveSet(const Eigen::Ref<const Eigen::MatrixXd>& M, const Eigen::Ref<const Eigen::VectorXd>& q,
                         Eigen::Ref<Eigen::VectorXd> z) const;

  // The complementarity error a solution may have: the tolerance, and a few ulps above it.
  double Accepted() const { return std::max(options_.tolerance, 64.0 * std::numeric_limits<double>::epsilon()); }

  LcpOptions options_;
  Eigen::VectorXd w_;     // scratch for Siconos' w output
  Eigen::VectorXd best_;  // the closest failed attempt's z, for PolishActiveSet
};

// Reads an LCP in Siconos Numerics' test-data format (numerics/src/LCP/test/data/*.dat)
// with Siconos' own reader; any storage is converted to dense. Returns false if unreadable.
[[nodiscard]] bool ReadSiconosLcpFile(const std::string& path, Eigen::MatrixXd* M, Eigen::VectorXd* q);

}  // namespace cosim::nonsmooth
