#pragma once
// What a scenario reader refuses: the InputError's message of `f`, or "(no error)".
#include <functional>
#include <string>

#include "interface/base/errors.h"

namespace cosim::interface {

inline std::string MessageOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace cosim::interface
