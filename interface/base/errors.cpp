#include "interface/base/errors.h"

#include <cstdio>
#include <cstdlib>

namespace cosim {

ExitCode PeerOutcome(int exit_code) {
  if (exit_code == static_cast<int>(ExitCode::kBadInput)) return ExitCode::kBadInput;
  if (exit_code == static_cast<int>(ExitCode::kNumericalFailure)) return ExitCode::kNumericalFailure;
  return ExitCode::kPeerFailure;
}

void ThrowAs(ExitCode code, const std::string& what) {
  switch (code) {
    case ExitCode::kBadInput:
      throw InputError(what);
    case ExitCode::kNumericalFailure:
      throw NumericalError(what);
    case ExitCode::kPeerFailure:
      throw PeerError(what);
    case ExitCode::kOk:
      break;
  }
  throw Error(code, what);
}

void AbortInvariant(const char* expr, const char* file, int line, const std::string& message) {
  std::fprintf(stderr, "internal error: %s:%d: invariant '%s' broken: %s\n", file, line, expr, message.c_str());
  std::abort();
}

}  // namespace cosim
