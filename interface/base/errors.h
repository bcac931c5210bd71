#pragma once
// The project's error types and the run contract's exit codes.
//
// Three tiers (docs/design.md): user-facing errors are exceptions derived from
// cosim::Error, each carrying the exit code the run ends with; broken invariants abort
// through COSIM_ASSERT; expensive checks are debug-only asserts.
#include <stdexcept>
#include <string>

namespace cosim {

enum class ExitCode : int {
  kOk = 0,
  kBadInput = 2,          // scenario, command line or protocol message is wrong
  kNumericalFailure = 3,  // a solve did not converge, an LCP failed its check, ...
  kPeerFailure = 4,       // a peer process died, hung or broke the protocol
};

class Error : public std::runtime_error {
 public:
  Error(ExitCode code, const std::string& what) : std::runtime_error(what), code_(code) {}
  ExitCode code() const { return code_; }

 private:
  ExitCode code_;
};

// Bad input: the message names the place (file:line:col or field path), the value found
// and what is expected.
class InputError : public Error {
 public:
  explicit InputError(const std::string& what) : Error(ExitCode::kBadInput, what) {}
};

class NumericalError : public Error {
 public:
  explicit NumericalError(const std::string& what) : Error(ExitCode::kNumericalFailure, what) {}
};

class PeerError : public Error {
 public:
  explicit PeerError(const std::string& what) : Error(ExitCode::kPeerFailure, what) {}
};

// The run's outcome when a peer process ended with `exit_code`: its bad input (2) or
// numerical failure (3) is the run's; anything else (4, a signal, nonsense) a peer failure.
ExitCode PeerOutcome(int exit_code);
// Throws the Error class of `code` (InputError, NumericalError, PeerError), so that callers
// that catch by class see a peer's failure as they would see their own.
[[noreturn]] void ThrowAs(ExitCode code, const std::string& what);

[[noreturn]] void AbortInvariant(const char* expr, const char* file, int line, const std::string& message);

}  // namespace cosim

// Always-on check of an invariant of the code itself (not of user input).
#define COSIM_ASSERT(expr, message)                                           \
  do {                                                                        \
    if (!(expr)) ::cosim::AbortInvariant(#expr, __FILE__, __LINE__, message); \
  } while (false)
