#pragma once
// Releasing Siconos SolverOptions completely (include after Siconos' SolverOptions.h, only in
// the lcp/ sources). Siconos 4.4's solver_options_delete clears the internal solvers' contents
// but leaves each internal SolverOptions struct allocated (a leak LeakSanitizer reports for
// every fc3d solve): free those first, then the options themselves.
#include <cstdlib>

namespace cosim::nonsmooth {

inline void FreeSolverOptions(SolverOptions* options) {
  if (options == nullptr) return;
  for (size_t i = 0; options->internalSolvers != nullptr && i < options->numberOfInternalSolvers; ++i) {
    FreeSolverOptions(options->internalSolvers[i]);
    options->internalSolvers[i] = nullptr;
  }
  solver_options_delete(options);  // tolerates the null entries
  std::free(options);
}

}  // namespace cosim::nonsmooth
