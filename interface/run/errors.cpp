#include "interface/run/errors.h"

#include <cstdio>
#include <cstdlib>

namespace cosim {

void AbortInvariant(const char* expr, const char* file, int line, const std::string& message) {
  std::fprintf(stderr, "internal error: %s:%d: invariant '%s' broken: %s\n", file, line, expr,
               message.c_str());
  std::abort();
}

}  // namespace cosim
