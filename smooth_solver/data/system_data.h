#pragma once
// Everything of a smooth model that changes during a run besides (q, q̇, q̈, λ): the coordinates
// a coupling peer imposes on the interface points, the contact laws' impact-speed memories and
// the rotors' inflow. The MultibodySystem (the model, like Pinocchio's Model or MuJoCo's mjModel)
// is immutable once built; MakeData(system) (multibody_system.h) makes this data from it, and its
// force elements and constraint rows are given it at every evaluation (AddForce(…, data, …),
// ConstraintSet::Evaluate(imposed, …)) and keep only their slots in it, never a pointer to it.
// Its owner (the simulation) writes it (AcceptStep after an accepted step; the coordinator's
// impact restarts); a coupled try's imposed coordinates come in as the step's input
// (InterfaceMotion, taken by CGα's TryStep). CGα's checkpoints save and restore it with the
// integrator's state, so that a rejected step (an adaptive step's error test, a coupling
// iteration that fails) leaves no trace (like Pinocchio's Data or MuJoCo's mjData).
#include <Eigen/Core>
#include <algorithm>
#include <stdexcept>
#include <vector>

#include "smooth_solver/constraints/bilinear_constraints.h"

namespace cosim::smooth {

// A rotor's frame and inflow, fixed over a step (smooth_solver/aero/air_loads.h).
struct RotorInflowState {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero(), n = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d x = Eigen::Vector3d::UnitX(), y = Eigen::Vector3d::UnitY();
  double v_normal = 0.0;  // V_⊥: free stream into the disk against n [m/s]
  double v_parallel = 0.0;
  Eigen::Vector3d downstream = Eigen::Vector3d::UnitX();  // in-plane free-stream direction
  double tip_speed = 0.0, fade = 0.0;
  Eigen::Vector3d nu = Eigen::Vector3d::Zero();  // ν0, ν_x, ν_y [m/s] (applied)
  double t = 0.0;
  bool started = false;
};

// One try's interface motion, a coupled step's input: the coordinates the peers impose at the
// step's end and the compliance that linearises them (as SystemData::imposed and
// interface_compliance, entry for entry). The coordinator fills it for each coupling iteration
// and CGα's TryStep takes it into the data it solves with; a checkpoint holds the step's start
// (SystemData), so restoring it leaves the try's input as it was given.
struct InterfaceMotion {
  std::vector<ImposedCoordinate> imposed;
  std::vector<Eigen::Matrix3d> compliance;
};

struct SystemData {
  // 3 per interface point (x, y, z): the end-of-step values the peer imposes; the coupling rows'
  // drives name them by index, and every evaluation of the constraints is given them.
  std::vector<ImposedCoordinate> imposed;
  // One per interface point: the peer's compliance as the coordinator linearised it, ∂x/∂λ of
  // the imposed position x with respect to the point's multipliers (interface Jacobians,
  // docs/protocol.md): the coupling rows read p(q) − x − (cI + C)λ = 0. Zero without.
  std::vector<Eigen::Matrix3d> interface_compliance;
  // δ̇⁻ of each UnilateralContact (force_elements.h), by its memory slot.
  std::vector<double> impact_speed;
  // One per rotor of the air loads.
  std::vector<RotorInflowState> rotors;

  // Whether `other` has this object's sizes (belongs to the same system).
  bool SameShape(const SystemData& other) const {
    return other.imposed.size() == imposed.size() && other.impact_speed.size() == impact_speed.size() &&
           other.interface_compliance.size() == interface_compliance.size() && other.rotors.size() == rotors.size();
  }
  // A try's interface motion into this data (same sizes: no reallocation).
  void TakeMotion(const InterfaceMotion& motion) {
    if (motion.imposed.size() != imposed.size() || motion.compliance.size() != interface_compliance.size()) {
      throw std::logic_error("SystemData::TakeMotion: the motion belongs to another system");
    }
    std::copy(motion.imposed.begin(), motion.imposed.end(), imposed.begin());
    std::copy(motion.compliance.begin(), motion.compliance.end(), interface_compliance.begin());
  }
  // Copies `other` into this object's storage (same sizes: no reallocation, as the checkpoints
  // of a warm run must not allocate).
  void CopyFrom(const SystemData& other) {
    if (!SameShape(other)) {
      throw std::logic_error("SystemData::CopyFrom: the two objects belong to different systems");
    }
    std::copy(other.imposed.begin(), other.imposed.end(), imposed.begin());
    std::copy(other.interface_compliance.begin(), other.interface_compliance.end(), interface_compliance.begin());
    std::copy(other.impact_speed.begin(), other.impact_speed.end(), impact_speed.begin());
    std::copy(other.rotors.begin(), other.rotors.end(), rotors.begin());
  }
};

}  // namespace cosim::smooth
