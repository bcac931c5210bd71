#pragma once
// Reference frames of a scenario (proto Reference, MBDyn's `reference` cards): named poses
// chained relative to one another, and elements written in them. ResolveReferences turns every
// frame into its global pose and every element written in a frame into global coordinates, so
// that no reader of the scenario needs to know about frames.
#include <google/protobuf/message.h>

#include <Eigen/Core>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "scenario.pb.h"

namespace cosim::interface {

// x ↦ rotation x + translation.
struct Pose {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Pose operator*(const Pose& inner) const;  // this ∘ inner
  Pose Inverse() const;
};

// How a pattern turned copy k: by `turn` in the axes of frame `frame` (a pattern's reference:
// the global turn is then F ∘ turn ∘ F⁻¹ with F the frame's global pose, known only once the
// frames are resolved), or in global axes if `frame` is empty. `axis` and `origin`: the turn's
// axis and a point on it, in the same axes; `pattern`: the pattern's field path, for errors.
struct CopyTurn {
  Pose turn;
  std::string frame;
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  std::string pattern;
};

// The pose of a rotation vector v (axis times angle) about the point `origin`.
Pose RotationAbout(const Eigen::Vector3d& v, const Eigen::Vector3d& origin);

// Maps every geometry-annotated 3-vector list of `message` and its sub-messages (the schema's
// `geometry` option) by `pose`: points x ↦ R x + t, directions d ↦ R d, rotation vectors v ↦ the
// rotation vector of R·R(v). With `skip_referenced`, a sub-message that sets `reference` (it is
// written in a frame, which moves instead) is left as it is. Lists of a length other than a
// multiple of 3 keep their extra values (the validator reports them).
void TransformGeometry(google::protobuf::Message* message, const Pose& pose, bool skip_referenced);

// Resolves model.references and every element's `reference`. `copy_pose(path)` is the pose by
// which a pattern turned the element at field path `path`, or nothing outside the patterns. An
// element M (or a frame) written in frame P is placed at
//   pose(M) = global(P) ∘ local(M)                                  M outside the patterns,
//   pose(M) = copy_pose(M) ∘ copy_pose(P)⁻¹ ∘ global(P) ∘ local(M)  M in a copy,
// with copy_pose(P) the identity for a P outside them: a copy sees P as the pattern's template
// saw it, and is turned with its copy (its own blade's frame, or the hub's turned). `fail(path,
// message)` must throw (InputError naming the place). Refused: a frame without a name, two with
// one name, an unknown frame (the defined ones are listed), frames that refer to each other in a
// cycle, a position or rotation that is not [x, y, z].
//
// A copy of a pattern with a `reference` frame F was left unturned by ExpandPatterns: its
// elements not written in a frame (`deferred`: each copied list element's path and turn) are
// turned here by F ∘ turn ∘ F⁻¹ once F is known, and those written in a frame through
// copy_pose. A copy of a pattern without one that hangs a frame or an element on a frame P
// outside the copy whose axes or origin do not turn with the copies (R_P a ≠ a, or P's origin off
// the axis) is refused: turned about the global axis it would come out coned or bent, not tilted.
void ResolveReferences(scenario::Scenario* proto,
                       const std::function<std::optional<CopyTurn>(const std::string&)>& copy_pose,
                       const std::vector<std::pair<std::string, CopyTurn>>& deferred,
                       const std::function<void(const std::string&, const std::string&)>& fail);

}  // namespace cosim::interface
