#include "interface/scenario/checks.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>

namespace cosim::interface {

void Checks::Require(const std::string& path, bool has, const std::string& what) const {
  if (!has) Fail(path, "missing; expected " + what);
}

double Checks::Positive(const std::string& path, bool has, double value, const std::string& unit) const {
  Require(path, has, "a positive value in " + unit);
  if (!(value > 0.0) || !std::isfinite(value)) {
    Fail(path, "must be positive (" + unit + "), got " + FormatNumber(value));
  }
  return value;
}

double Checks::NonNegative(const std::string& path, double value, const std::string& unit) const {
  if (!(value >= 0.0) || !std::isfinite(value)) {
    Fail(path, "must be >= 0 (" + unit + "), got " + FormatNumber(value));
  }
  return value;
}

double Checks::InRange(const std::string& path, bool has, double value, double lo, double hi, bool lo_open,
                       bool hi_open) const {
  const std::string range =
      std::string(lo_open ? "(" : "[") + FormatNumber(lo) + ", " + FormatNumber(hi) + (hi_open ? ")" : "]");
  Require(path, has, "a value in " + range);
  const bool above = lo_open ? value > lo : value >= lo;
  const bool below = hi_open ? value < hi : value <= hi;
  if (!(above && below)) Fail(path, "must be in " + range + ", got " + FormatNumber(value));
  return value;
}

Eigen::Vector3d Checks::Vector3(const std::string& path, const google::protobuf::RepeatedField<double>& values,
                                const std::optional<Eigen::Vector3d>& fallback) const {
  if (values.empty() && fallback) return *fallback;
  if (values.size() != 3) {
    Fail(path, "expected 3 components [x, y, z], got " + std::to_string(values.size()));
  }
  Eigen::Vector3d v(values.Get(0), values.Get(1), values.Get(2));
  if (!v.allFinite()) Fail(path, "components must be finite numbers");
  return v;
}

Eigen::Vector3d Checks::Direction(const std::string& path,
                                  const google::protobuf::RepeatedField<double>& values) const {
  const Eigen::Vector3d v = Vector3(path, values, std::nullopt);
  const double norm = v.norm();
  if (!(norm > 1e-12)) {
    Fail(path, "must be a non-zero direction, got [" + FormatNumber(v.x()) + ", " + FormatNumber(v.y()) + ", " +
                   FormatNumber(v.z()) + "]");
  }
  return v / norm;
}

Eigen::Vector3d Checks::AcrossAxis(const std::string& path, const google::protobuf::RepeatedField<double>& values,
                                   const Eigen::Vector3d& axis) const {
  const Eigen::Vector3d given = Direction(path, values);
  const Eigen::Vector3d across = given - given.dot(axis) * axis;
  if (across.norm() < 1e-6) Fail(path, "is parallel to axis; it must point across the span");
  return across.normalized();
}

std::string Checks::Name(const std::string& path, bool has, const std::string& value) const {
  Require(path, has, "a name of letters, digits, '_', '.' or '-'");
  if (value.empty()) Fail(path, "must not be empty");
  for (char c : value) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '.' && c != '-') {
      Fail(path, "'" + value + "' contains '" + std::string(1, c) + "'; use letters, digits, '_', '.' or '-'");
    }
  }
  // Names become file and folder names (a run's output folder, a contact process's subfolder):
  // "." and ".." would write into the folder itself or its parent.
  if (value.find_first_not_of('.') == std::string::npos) {
    Fail(path, "'" + value + "' is not a name (only dots: it would name a folder or its parent)");
  }
  if (value.size() > kMaxNameLength) {
    Fail(path, "'" + value.substr(0, 20) + "...' has " + std::to_string(value.size()) + " characters; at most " +
                   std::to_string(kMaxNameLength));
  }
  return value;
}

void Checks::StateTime(const std::string& what, double state_time, double start_time) const {
  if (std::abs(state_time - start_time) <= 1e-9 * std::max(1.0, std::abs(start_time))) return;
  Fail("numerics.initial_state",
       what + " is at t = " + FormatNumber(state_time) + " s but numerics.start_time is " + FormatNumber(start_time) +
           " s; expected them equal (--set numerics.start_time=" + FormatNumber(state_time) + ")");
}

std::string ElementPath(const std::string& list, int index) { return list + "[" + std::to_string(index) + "]"; }

std::string NameTable::Declare(const std::string& path, bool has, const std::string& name) {
  Add(path, checks_.Name(path, has, name));
  return name;
}

int ProbeComponent(const Checks& checks, const std::string& path, const scenario::Probe& p, bool vector) {
  if (!vector) {
    if (p.component() != scenario::Probe::COMPONENT_UNSPECIFIED) {
      checks.Fail(path + ".component", "this quantity is a scalar; leave component out");
    }
    return 0;
  }
  switch (p.component()) {
    case scenario::Probe::X:
      return 0;
    case scenario::Probe::Y:
      return 1;
    case scenario::Probe::Z:
      return 2;
    case scenario::Probe::NORM:
      return 3;
    default:
      checks.Fail(path + ".component", "this quantity is a vector; give X, Y, Z or NORM");
  }
}

void NameTable::Add(const std::string& path, const std::string& name) {
  if (index_.count(name) != 0) {
    checks_.Fail(path, kind_ + " name '" + name + "' is already used by " + where_[name] + "; names must be unique");
  }
  const int next = static_cast<int>(index_.size());
  index_[name] = next;
  where_[name] = path;
}

int NameTable::Find(const std::string& path, const std::string& name) const {
  auto it = index_.find(name);
  if (it == index_.end()) {
    std::string known;
    for (const auto& [n, i] : index_) known += (known.empty() ? "" : ", ") + n;
    checks_.Fail(path, "no " + kind_ + " named '" + name + "'" +
                           (known.empty() ? " (the scenario defines none)" : "; known: " + known));
  }
  return it->second;
}

}  // namespace cosim::interface
