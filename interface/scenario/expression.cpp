#include "interface/scenario/expression.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <map>
#include <numbers>
#include <vector>

#include "interface/base/errors.h"
#include "interface/scenario/checks.h"

namespace cosim::interface {
namespace {

// Recursive descent over
//   sum     := product (("+" | "-") product)*
//   product := unary (("*" | "/") unary)*
//   unary   := ("+" | "-") unary | power
//   power   := atom (("^" | "**") unary)?        (right associative: 2^3^2 = 2^9)
//   atom    := number | name | name "(" sum ("," sum)* ")" | "(" sum ")"
class Parser {
 public:
  Parser(const std::string& text, const NameLookup& lookup, const std::string& context, const std::string& known)
      : s_(text), lookup_(lookup), context_(context), known_(known) {}

  double Parse() {
    const double v = Sum();
    Skip();
    if (i_ < s_.size()) Fail("unexpected '" + std::string(1, s_[i_]) + "'");
    return v;
  }

 private:
  // "<context>: '<text>' at column <c>: <what>", with what an expression may hold unless the
  // mistake is a name.
  [[noreturn]] void Fail(const std::string& what, bool syntax = true) const {
    throw InputError(context_ + ": '" + EchoedText(s_) + "' at column " + std::to_string(i_ + 1) + ": " + what +
                     (syntax ? " (an expression holds numbers, parameters, + - * / ^, parentheses and sin, cos, tan, "
                               "asin, acos, atan, atan2, sqrt, exp, log, abs, min, max, radians, degrees, pi)"
                             : ""));
  }
  void Skip() {
    while (i_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[i_]))) ++i_;
  }
  bool Eat(const std::string& token) {
    Skip();
    if (s_.compare(i_, token.size(), token) != 0) return false;
    i_ += token.size();
    return true;
  }
  double Sum() {
    double v = Product();
    for (;;) {
      if (Eat("+")) {
        v += Product();
      } else if (Eat("-")) {
        v -= Product();
      } else {
        return v;
      }
    }
  }
  double Product() {
    double v = Unary();
    for (;;) {
      if (Eat("*")) {
        v *= Unary();
      } else if (Eat("/")) {
        v /= Unary();
      } else {
        return v;
      }
    }
  }
  double Unary() {
    const Nest nest(this);
    if (Eat("-")) return -Unary();
    if (Eat("+")) return Unary();
    return Power();
  }
  double Power() {
    const double base = Atom();
    if (Eat("^") || Eat("**")) return std::pow(base, Unary());
    return base;
  }
  double Atom() {
    Skip();
    if (i_ >= s_.size()) Fail("the expression ends where a value is expected");
    const char c = s_[i_];
    if (Eat("(")) {
      const Nest nest(this);
      const double v = Sum();
      if (!Eat(")")) Fail("a ')' is missing");
      return v;
    }
    if (std::isdigit(static_cast<unsigned char>(c)) || c == '.') {
      const char* start = s_.c_str() + i_;
      char* end = nullptr;
      const double v = std::strtod(start, &end);
      if (end == start) Fail("a number is malformed");
      i_ += static_cast<size_t>(end - start);
      return v;
    }
    if (std::isalpha(static_cast<unsigned char>(c)) || c == '_') {
      const size_t begin = i_;
      while (i_ < s_.size() && (std::isalnum(static_cast<unsigned char>(s_[i_])) || s_[i_] == '_')) ++i_;
      const std::string name = s_.substr(begin, i_ - begin);
      if (Eat("(")) return Call(name, begin);
      if (const std::optional<double> v = lookup_(name)) return *v;
      if (name == "pi") return std::numbers::pi;
      i_ = begin;
      Fail("no parameter '" + name + "'" + (known_.empty() ? "" : "; " + known_), false);
    }
    Fail("unexpected '" + std::string(1, c) + "'");
  }
  double Call(const std::string& name, size_t at) {
    std::vector<double> args{Sum()};
    while (Eat(",")) args.push_back(Sum());
    if (!Eat(")")) Fail("a ')' is missing after the arguments of " + name);
    static const std::map<std::string, double (*)(double)> one = {
        {"sin", [](double x) { return std::sin(x); }},
        {"cos", [](double x) { return std::cos(x); }},
        {"tan", [](double x) { return std::tan(x); }},
        {"asin", [](double x) { return std::asin(x); }},
        {"acos", [](double x) { return std::acos(x); }},
        {"atan", [](double x) { return std::atan(x); }},
        {"sqrt", [](double x) { return std::sqrt(x); }},
        {"exp", [](double x) { return std::exp(x); }},
        {"log", [](double x) { return std::log(x); }},
        {"abs", [](double x) { return std::abs(x); }},
        {"radians", [](double x) { return x * std::numbers::pi / 180.0; }},
        {"degrees", [](double x) { return x * 180.0 / std::numbers::pi; }}};
    static const std::map<std::string, double (*)(double, double)> two = {
        {"atan2", [](double y, double x) { return std::atan2(y, x); }},
        // (A NaN argument gives a NaN, refused as not finite: std::max(1, nan) is 1.)
        {"min", [](double a, double b) { return std::isnan(a) || std::isnan(b) ? a + b : std::min(a, b); }},
        {"max", [](double a, double b) { return std::isnan(a) || std::isnan(b) ? a + b : std::max(a, b); }}};
    if (const auto f = one.find(name); f != one.end()) {
      if (args.size() != 1) ArgumentCount(name, at, 1, args.size());
      return f->second(args[0]);
    }
    if (const auto f = two.find(name); f != two.end()) {
      if (args.size() != 2) ArgumentCount(name, at, 2, args.size());
      return f->second(args[0], args[1]);
    }
    i_ = at;
    Fail("no function '" + name + "'");
  }
  [[noreturn]] void ArgumentCount(const std::string& name, size_t at, size_t expected, size_t got) {
    i_ = at;
    Fail(name + " takes " + std::to_string(expected) + " argument" + (expected == 1 ? "" : "s") + ", got " +
         std::to_string(got));
  }

  // Nesting (signs and parentheses) is bounded: a hostile `${((((…` must not exhaust the stack.
  struct Nest {
    explicit Nest(Parser* p) : parser(p) {
      if (++parser->depth_ > kMaxDepth) parser->Fail("nested more than " + std::to_string(kMaxDepth) + " deep");
    }
    ~Nest() { --parser->depth_; }
    Nest(const Nest&) = delete;
    Nest& operator=(const Nest&) = delete;
    Parser* parser;
  };
  static constexpr int kMaxDepth = 200;
  int depth_ = 0;

  const std::string& s_;
  const NameLookup& lookup_;
  const std::string& context_;
  const std::string& known_;
  size_t i_ = 0;
};

}  // namespace

double EvaluateExpression(const std::string& text, const NameLookup& lookup, const std::string& context,
                          const std::string& known) {
  Parser parser(text, lookup, context, known);
  const double v = parser.Parse();
  if (!std::isfinite(v)) {
    throw InputError(context + ": '" + EchoedText(text) + "' is " +
                     (std::isnan(v) ? std::string("not a number (NaN)")
                      : v > 0       ? "+inf"
                                    : "-inf") +
                     "; expected a finite number");
  }
  return v;
}

}  // namespace cosim::interface
