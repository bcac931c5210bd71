#pragma once
// The quantities the smooth solver records (output.probes), read against the model. One table
// row per quantity says what its entity names, whether it has x, y, z components, may be
// expressed in a body's frame, or takes a station; the reader, the refusal that lists what is
// recorded and the frame and station rules all come from that table, so a new quantity is one
// row (and its value in MultibodySimulation::Probe).
#include <Eigen/Dense>
#include <string>
#include <vector>

#include "interface/scenario/checks.h"
#include "interface/scenario/scenario_file.h"
#include "smooth_solver/elastic/elastic_model.h"
#include "smooth_solver/model/multibody_model.h"

namespace cosim::smooth {

struct SmoothProbe {
  enum class Kind {
    kPosition,
    kVelocity,
    kAcceleration,
    kAngularVelocity,
    kJointCoordinate,
    kJointSpeed,
    kReactionForce,
    kReactionMoment,
    kKinetic,
    kPotential,
    kTotal,
    kViolation,
    kDisplacement,
    kStrainEnergy,
    kClampForce,
    kClampMoment,
    kBodyDisplacement,
    kRotation,
    kBeamStrainEnergy,
    kSectionForce,
    kSectionMoment,
    kAeroAlpha,
    kAeroForce,
    kAeroMoment,
    kAeroMach,
    kRotorThrust,
    kRotorTorque,
    kInflowRatio,
    kInducedVelocity,
    kContactForce
  };
  std::string name;
  Kind kind = Kind::kPosition;
  int index = -1;
  int component = 0;     // 0-2 x, y, z; 3 norm
  int node = 0;          // elastic-body probes
  int frame = -1;        // body whose frame vectors are expressed in (−1: global)
  double station = 0.0;  // section probes: span coordinate
  // Initial position (relative to the frame, in its axes) and orientation (relative to the
  // frame) of the body: displacement and rotation are measured from them (set once the
  // initial state is known).
  Eigen::Vector3d initial_position = Eigen::Vector3d::Zero();
  Eigen::Matrix3d initial_orientation = Eigen::Matrix3d::Identity();
};

// output.probes of the smooth model, in order (in a coupled run, the probes of contact nodes
// and contacts are the contact processes'); InputError naming the probe's field for a probe
// the model cannot record.
std::vector<SmoothProbe> ReadSmoothProbes(const interface::Checks& checks, const interface::ScenarioFile& file,
                                          bool coupled, const MultibodyModel& model,
                                          const std::vector<ElasticBodySpec>& elastic);

}  // namespace cosim::smooth
