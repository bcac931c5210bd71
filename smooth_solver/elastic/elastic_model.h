#pragma once
// Elastic bodies as given in a scenario (model.elastic_bodies), validated: material, mesh
// (beam description or node/element lists, every element checked for inversion), clamps and
// node loads. Throws InputError naming the field.
#include <string>
#include <vector>

#include "interface/scenario/checks.h"
#include "smooth_solver/elastic/elastic_body.h"
#include "smooth_solver/model/multibody_model.h"

namespace cosim::smooth {

struct ElasticBodySpec {
  std::string name;
  ElasticBody body;
  double strain_damping = 0.0;  // ξ of the GEMM midpoint force, >= 0
  struct Clamp {
    int rigid_body = -1;  // −1: ground
    std::vector<int> nodes;
  };
  std::vector<Clamp> clamps;
  std::vector<std::pair<int, Eigen::Vector3d>> loads;  // (node, force [N])
  // Node named by a probe's `point`: a 0-based index, "tip_centre" or "root_centre".
  int FindPoint(const interface::Checks& checks, const std::string& path, const std::string& point) const;
};

std::vector<ElasticBodySpec> BuildElasticBodies(const interface::Checks& checks, const scenario::Model& model,
                                                const std::vector<RigidBody>& bodies);

}  // namespace cosim::smooth
