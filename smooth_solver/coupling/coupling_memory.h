#pragma once
// What the next coupled step starts from: the accepted steps' reactions and node motion, the
// interface rows' multipliers at the step's start, and the peers' last affine law. It is what a
// saved state holds of a coupled run (state.proto's CoordinatorMemory), written and read through
// one table of its fields (kVectorFields), so that saving, restoring and the restore's checks
// cannot disagree on a field.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "state.pb.h"

namespace cosim::smooth {

struct CouplingMemory {
  explicit CouplingMemory(int points);

  // The reactions the peers held in the last two accepted steps [N], per interface value (3 per
  // point), and how many steps have been accepted since the start or the last impact (the
  // predictor extrapolates from two).
  Eigen::VectorXd accepted_x, previous_accepted_x;
  long long accepted_steps = 0;
  double accepted_h = 0.0, previous_accepted_h = 0.0;  // [s]
  // The interface rows' multipliers λ at the step's start and their CGα-filtered values λ̃.
  Eigen::VectorXd lambda_start, filtered_start;
  // The nodes' motion in the last accepted step and the one before.
  Eigen::VectorXd accepted_position, accepted_velocity, accepted_acceleration;
  Eigen::VectorXd previous_accepted_position, previous_accepted_velocity;
  // The peers' affine law at the last accepted step, k = a + S x: a, and S (9 per point,
  // row-major); whether a holds for the next step's predicted law.
  Eigen::VectorXd accepted_offset, sensitivity;
  bool offset_known = false;
  std::vector<bool> was_contact;  // per point: in contact in the last accepted step

  // S of point k, and S of every point from and into per-point blocks.
  Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> Sensitivity(int k) const;
  void SetSensitivities(const std::vector<Eigen::Matrix3d>& blocks);
  void GetSensitivities(std::vector<Eigen::Matrix3d>* blocks) const;

  // Into a saved state (its relaxation memory is the relaxation's own).
  void Write(state::CoordinatorMemory* out) const;
  // From a saved state: the reason it is refused (another number of points, sizes that do not
  // match, non-finite values or step lengths), nothing changed; empty if none.
  [[nodiscard]] std::string Read(const state::CoordinatorMemory& in);

 private:
  int points_ = 0;
};

}  // namespace cosim::smooth
