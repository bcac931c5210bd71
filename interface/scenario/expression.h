#pragma once
// Arithmetic expressions of a scenario's parameters (Scenario.parameters and the `${…}` that use
// them, docs/design.md "Parameters"): numbers, names, + − * / and ^ or ** (power, right
// associative), unary ±, parentheses, the functions sin cos tan asin acos atan sqrt exp log
// abs radians degrees of one argument and atan2 min max of two, and the constant pi.
#include <functional>
#include <optional>
#include <string>

namespace cosim::interface {

// A name's value, or nothing if there is no such name.
using NameLookup = std::function<std::optional<double>(const std::string&)>;

// The value of `text`. Throws InputError "<context>: '<text>' at column <c>: <what>" for a
// syntax error, an unknown name (followed by `known`, e.g. "defined: R, c"), or a result that is
// not finite.
double EvaluateExpression(const std::string& text, const NameLookup& lookup, const std::string& context,
                          const std::string& known);

}  // namespace cosim::interface
