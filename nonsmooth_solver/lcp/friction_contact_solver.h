#pragma once
// Three-dimensional Coulomb friction-contact problems  u = W r + q  with r in the cone
// K_μ = {|r_t| <= μ r_n} and the modified velocity û = (u_n + μ|u_t|, u_t) in its dual,
// r ⟂ û (De Saxcé), solved by Siconos Numerics' fc3d driver (NSGS). Each contact's block is
// (normal, tangent 1, tangent 2). As for LCPs, the answer is checked here independently.
#include <Eigen/Core>
#include <string>

namespace cosim::nonsmooth {

struct FrictionContactResult {
  bool solved = false;
  int siconos_info = 0;
  int iterations = 0;
  double error = 0.0;  // see FrictionContactError
  std::string message;
};

// max over contacts of |r − P_K(r − û)|∞ / (1 + |q|∞): zero exactly at a solution.
double FrictionContactError(const Eigen::Ref<const Eigen::MatrixXd>& W, const Eigen::Ref<const Eigen::VectorXd>& q,
                            const Eigen::Ref<const Eigen::VectorXd>& mu, const Eigen::Ref<const Eigen::VectorXd>& r);

// Solves for r (size 3 × contacts). `tolerance` bounds the error above; `max_iterations` the
// NSGS sweeps.
FrictionContactResult SolveFrictionContact(const Eigen::Ref<const Eigen::MatrixXd>& W,
                                           const Eigen::Ref<const Eigen::VectorXd>& q,
                                           const Eigen::Ref<const Eigen::VectorXd>& mu, double tolerance,
                                           int max_iterations, Eigen::Ref<Eigen::VectorXd> r);

}  // namespace cosim::nonsmooth
