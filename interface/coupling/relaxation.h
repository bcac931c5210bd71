#pragma once
// Acceleration of the coupling's fixed-point iteration inside a time step. The interface
// data x (the reactions the coordinator sends) go through one Gauss–Seidel sweep — contact
// step, then smooth step — which returns x̃ = H(x); the coupling converges when the residual
// r = x̃ − x vanishes. Given the current x_i and x̃_i, Next() proposes x_{i+1}:
//
//   CONSTANT  x_{i+1} = x_i + ω r_i (ω = relaxation_factor)
//   AITKEN    the same with a dynamic ω (Irons–Tuck, as in Küttler & Wall 2008):
//             ω_i = −ω_{i−1} r_{i−1}ᵀ(r_i − r_{i−1}) / |r_i − r_{i−1}|², limited to [−2, 2]; each
//             step starts again from the factor (the previous step's last ω would carry a
//             stale curvature into it); a stalled residual (r_i = r_{i−1}) keeps the last ω
//   IQN_ILS   interface quasi-Newton with inverse Jacobian from a least-squares fit (Degroote,
//             Bathe & Vierendeels 2009): V = [Δr], W = [Δx̃] over this step's iterations,
//             α = argmin |V α + r_i|, x_{i+1} = x̃_i + W α; the first iteration of a step is
//             a constant-ω one unless columns of earlier steps are reused: IQN-ILS(q)
//             (Degroote, Haelterman, Annerel, Bruggeman & Vierendeels 2010) keeps the columns of
//             the last q steps, so a step starts with the secant Jacobian of the ones before —
//             the difference between ~6 and ~2 iterations on a stiff tie (a regularised
//             coincidence of a light node). The least-squares problem is solved by a column-pivoting QR;
//             columns that are (numerically) dependent — a stalled iteration repeats itself —
//             are dropped, oldest first, so the fit never divides by ~0.
//
// A zero residual proposes x̃ itself (nothing to relax). The vectors are sized once; the
// IQN-ILS least-squares fit allocates its small QR (size × columns) per iteration.
#include <Eigen/Core>
#include <Eigen/QR>
#include <string>
#include <vector>

#include "state.pb.h"

namespace cosim::interface {

class Relaxation {
 public:
  enum class Method { kConstant, kAitken, kIqnIls };
  // `size`: length of x; `factor`: ω of CONSTANT and of every method's first iteration;
  // `max_columns`: IQN-ILS columns kept (default: as many as `size`); `reuse_steps`: IQN-ILS
  // columns of up to that many earlier steps are kept (0: each step starts afresh).
  Relaxation(Method method, int size, double factor, int max_columns = -1, int reuse_steps = 0);

  void BeginStep();  // a new step: drop the history older than `reuse_steps`
  void Forget();     // drop all history (the interface map changed: an impact, a restart)
  // x_{i+1} from x_i and x̃_i = H(x_i).
  void Next(const Eigen::VectorXd& x, const Eigen::VectorXd& x_tilde, Eigen::VectorXd* x_next);

  double last_factor() const { return omega_; }  // the ω of the last update (Aitken, constant)
  int columns() const { return columns_; }       // IQN-ILS columns in use

  // What a later step starts from (IQN-ILS's columns kept by reuse_steps), for a restart.
  void Write(state::RelaxationMemory* out) const;
  // Reads a Write of a relaxation of this method, reuse_steps and size (`*restored`); another
  // one is left (the restart's relaxation starts afresh: `*restored` false). A memory of this
  // kind that cannot be one (more columns than kept, sizes that do not match, non-finite
  // values) is refused: the reason, and nothing changed; empty if none.
  [[nodiscard]] std::string Read(const state::RelaxationMemory& in, bool* restored);

 private:
  Method method_;
  double factor_, omega_;
  int iteration_ = 0, max_columns_, columns_ = 0, reuse_steps_, step_ = 0;
  std::vector<int> stamp_;  // the step each IQN-ILS column was made in
  Eigen::VectorXd r_, r_previous_, x_tilde_previous_, dr_, alpha_;
  Eigen::MatrixXd V_, W_;  // size × max_columns, newest column first
};

}  // namespace cosim::interface
