#pragma once
// Scenario patterns (proto Pattern): elements written once and placed N times about an axis —
// a rotor's blades. ExpandPatterns turns `patterns` into ordinary list elements of the scenario,
// before any reader sees it, and records where each copy came from so that errors about a copy
// name the template's line.
#include <functional>
#include <string>
#include <vector>

#include "interface/scenario/reference_frames.h"
#include "scenario.pb.h"

namespace cosim::interface {

// Where an expanded list element came from.
struct PatternOrigin {
  std::string expanded;  // e.g. "model.bodies[5]"
  std::string source;    // e.g. "patterns[0].each.model.bodies[1]"
  std::string pattern;   // the pattern's name
  int copy = 0;          // k, 1-based
  CopyTurn turn;         // the copy's rotation about the pattern's axis (in its frame, if it names one)
};

// Expands and clears proto->patterns. `fail(path, message)` must throw (InputError with the
// place). Checks: name, count in 1..1000, axis non-zero, `each` setting only lists, names
// unique across patterns.
std::vector<PatternOrigin> ExpandPatterns(scenario::Scenario* proto,
                                          const std::function<void(const std::string&, const std::string&)>& fail);

}  // namespace cosim::interface
