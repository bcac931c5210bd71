#include "smooth_solver/coupling/coupling_memory.h"

#include <cmath>
#include <string>

#include "smooth_solver/simulation/saved_state.h"

namespace cosim::smooth {

namespace {

using Repeated = google::protobuf::RepeatedField<double>;

// One vector of the memory: its name in state.proto, where it is in CouplingMemory and in the
// saved message, and its values per interface point.
struct VectorField {
  const char* name;
  Eigen::VectorXd CouplingMemory::*value;
  const Repeated& (state::CoordinatorMemory::*saved)() const;
  Repeated* (state::CoordinatorMemory::*mutable_saved)();
  int per_point;
};

using M = CouplingMemory;
using S = state::CoordinatorMemory;
constexpr VectorField kVectorFields[] = {
    {"accepted_x", &M::accepted_x, &S::accepted_x, &S::mutable_accepted_x, 3},
    {"previous_accepted_x", &M::previous_accepted_x, &S::previous_accepted_x, &S::mutable_previous_accepted_x, 3},
    {"lambda_start", &M::lambda_start, &S::lambda_start, &S::mutable_lambda_start, 3},
    {"filtered_start", &M::filtered_start, &S::filtered_start, &S::mutable_filtered_start, 3},
    {"accepted_position", &M::accepted_position, &S::accepted_position, &S::mutable_accepted_position, 3},
    {"accepted_velocity", &M::accepted_velocity, &S::accepted_velocity, &S::mutable_accepted_velocity, 3},
    {"accepted_acceleration", &M::accepted_acceleration, &S::accepted_acceleration, &S::mutable_accepted_acceleration,
     3},
    {"previous_accepted_position", &M::previous_accepted_position, &S::previous_accepted_position,
     &S::mutable_previous_accepted_position, 3},
    {"previous_accepted_velocity", &M::previous_accepted_velocity, &S::previous_accepted_velocity,
     &S::mutable_previous_accepted_velocity, 3},
    {"accepted_offset", &M::accepted_offset, &S::accepted_offset, &S::mutable_accepted_offset, 3},
    {"sensitivity", &M::sensitivity, &S::sensitivity, &S::mutable_sensitivity, 9},
};
constexpr int kFields = sizeof(kVectorFields) / sizeof(kVectorFields[0]);

}  // namespace

CouplingMemory::CouplingMemory(int points) : was_contact(static_cast<size_t>(points), false), points_(points) {
  for (const VectorField& f : kVectorFields) this->*f.value = Eigen::VectorXd::Zero(f.per_point * points);
}

Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> CouplingMemory::Sensitivity(int k) const {
  return Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(sensitivity.data() + 9 * k);
}

void CouplingMemory::SetSensitivities(const std::vector<Eigen::Matrix3d>& blocks) {
  for (size_t k = 0; k < blocks.size(); ++k) {
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(sensitivity.data() + 9 * k) = blocks[k];
  }
}

void CouplingMemory::GetSensitivities(std::vector<Eigen::Matrix3d>* blocks) const {
  for (size_t k = 0; k < blocks->size(); ++k) (*blocks)[k] = Sensitivity(static_cast<int>(k));
}

void CouplingMemory::Write(state::CoordinatorMemory* out) const {
  out->set_points(points_);
  for (const VectorField& f : kVectorFields) AddValues(this->*f.value, (out->*f.mutable_saved)());
  out->set_accepted_steps(accepted_steps);
  out->set_accepted_h(accepted_h);
  out->set_previous_accepted_h(previous_accepted_h);
  out->set_offset_known(offset_known);
  for (const bool c : was_contact) out->add_was_contact(c);
}

std::string CouplingMemory::Read(const state::CoordinatorMemory& in) {
  if (in.points() != points_) {
    return "its coordinator's memory is of " + std::to_string(in.points()) + " interface points, not " +
           std::to_string(points_);
  }
  // Read into copies: a refused memory changes nothing.
  Eigen::VectorXd read[kFields];
  for (int i = 0; i < kFields; ++i) {
    const VectorField& f = kVectorFields[i];
    const Repeated& values = (in.*f.saved)();
    const int size = f.per_point * points_;
    if (!ReadValues(values, size, &read[i])) {
      return std::string("its coordinator's ") + f.name + " has " + std::to_string(values.size()) + " values, not " +
             std::to_string(size);
    }
    if (std::string bad = NonFinite({{f.name, &values}}, "coordinator's "); !bad.empty()) return bad;
  }
  if (in.was_contact_size() != points_) {
    return "its coordinator's was_contact has " + std::to_string(in.was_contact_size()) + " values, not " +
           std::to_string(points_);
  }
  if (!std::isfinite(in.accepted_h()) || !std::isfinite(in.previous_accepted_h()) || in.accepted_h() < 0.0 ||
      in.previous_accepted_h() < 0.0 || in.accepted_steps() < 0) {
    return "its coordinator's accepted_h, previous_accepted_h or accepted_steps is not a step length or count";
  }
  for (int i = 0; i < kFields; ++i) this->*kVectorFields[i].value = std::move(read[i]);
  accepted_steps = in.accepted_steps();
  accepted_h = in.accepted_h();
  previous_accepted_h = in.previous_accepted_h();
  offset_known = in.offset_known();
  for (int k = 0; k < points_; ++k) was_contact[static_cast<size_t>(k)] = in.was_contact(k);
  return {};
}

}  // namespace cosim::smooth
