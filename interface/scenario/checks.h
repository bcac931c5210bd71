#pragma once
// Validation helpers shared by the solvers' model builders. Each check either returns the
// validated value or throws InputError through ScenarioFile::Fail, naming the place, the
// value found and what is expected.
#include <google/protobuf/repeated_field.h>

#include <Eigen/Core>
#include <map>
#include <optional>
#include <string>

#include "interface/base/text.h"
#include "interface/scenario/message_tree.h"
#include "interface/scenario/scenario_file.h"

namespace cosim::interface {

class Checks {
 public:
  explicit Checks(const ScenarioFile& file) : file_(file) {}

  const ScenarioFile& file() const { return file_; }
  [[noreturn]] void Fail(const std::string& path, const std::string& message) const { file_.Fail(path, message); }

  // A present field (for fields without a default whose absence would be ambiguous).
  void Require(const std::string& path, bool has, const std::string& what) const;
  double Positive(const std::string& path, bool has, double value, const std::string& unit) const;
  double NonNegative(const std::string& path, double value, const std::string& unit) const;
  // value in [lo, hi] (closed) unless the bound is marked open.
  double InRange(const std::string& path, bool has, double value, double lo, double hi, bool lo_open = false,
                 bool hi_open = false) const;
  // A 3-vector given as [x, y, z]; `fallback` used when the list is empty (absent).
  Eigen::Vector3d Vector3(const std::string& path, const google::protobuf::RepeatedField<double>& values,
                          const std::optional<Eigen::Vector3d>& fallback) const;
  // A non-zero 3-vector, returned normalised.
  Eigen::Vector3d Direction(const std::string& path, const google::protobuf::RepeatedField<double>& values) const;
  // A direction across the unit `axis` (a section's chord): its part normal to the axis,
  // normalised; InputError if it is parallel to the axis.
  Eigen::Vector3d AcrossAxis(const std::string& path, const google::protobuf::RepeatedField<double>& values,
                             const Eigen::Vector3d& axis) const;
  // A name: present, [A-Za-z0-9_.-]+, not only dots, at most kMaxNameLength characters.
  static constexpr size_t kMaxNameLength = 128;
  std::string Name(const std::string& path, bool has, const std::string& value) const;
  // A saved state (numerics.initial_state; `what` says which, e.g. "the state") written at
  // `state_time` starts a run at numerics.start_time `start_time`: equal to 1e-9 relative, else
  // InputError naming numerics.initial_state and the --set that makes them equal.
  void StateTime(const std::string& what, double state_time, double start_time) const;

 private:
  const ScenarioFile& file_;
};

// The component of a probe (proto Probe.component): 0, 1, 2 for X, Y, Z, 3 for NORM when the
// quantity is a vector; 0 (and none given) when it is a scalar. InputError otherwise.
int ProbeComponent(const Checks& checks, const std::string& probe_path, const scenario::Probe& probe, bool vector);
// A 3-vector's component as chosen by ProbeComponent.
inline double PickComponent(const Eigen::Vector3d& v, int component) {
  return component == 3 ? v.norm() : v(component);
}

// Names of one kind of entity, checked unique, looked up by reference fields.
class NameTable {
 public:
  NameTable(const Checks& checks, std::string kind) : checks_(checks), kind_(std::move(kind)) {}
  void Add(const std::string& path, const std::string& name);
  // Checks the name field at `path` (Checks::Name), adds it, and returns it.
  std::string Declare(const std::string& path, bool has, const std::string& name);
  bool Contains(const std::string& name) const { return index_.count(name) != 0; }
  // Index of `name`, or InputError at `path` listing the known names.
  int Find(const std::string& path, const std::string& name) const;
  int size() const { return static_cast<int>(index_.size()); }

 private:
  const Checks& checks_;
  std::string kind_;
  std::map<std::string, int> index_;
  std::map<std::string, std::string> where_;
};

}  // namespace cosim::interface
