#pragma once
// Elastic bodies as given in a scenario (model.elastic_bodies), validated: material, mesh
// (beam description or node/element lists, every element checked for inversion), clamps and
// node loads. Throws InputError naming the field.
#include <string>
#include <vector>

#include "interface/scenario/checks.h"
#include "interface/scenario/time_function.h"
#include "smooth_solver/elastic/elastic_body.h"

namespace cosim::smooth {

struct ElasticBodySpec {
  std::string name;
  ElasticBody body;
  double strain_damping = 0.0;    // ξ of the GEMM midpoint force, >= 0
  double retardation_time = 0.0;  // β of the Kelvin–Voigt structural damping [s], >= 0
  struct Clamp {
    int rigid_body = -1;  // −1: ground
    std::vector<int> nodes;
  };
  std::vector<Clamp> clamps;
  struct Load {
    int node = -1;
    Eigen::Vector3d force = Eigen::Vector3d::Zero();  // [N]
    interface::TimeFunction factor = interface::TimeFunction::Constant(1.0);
    bool time_varying = false;  // a factor was given
  };
  std::vector<Load> loads;
  // Node named by a probe's `point`: a 0-based index, "tip_centre" or "root_centre".
  int FindPoint(const interface::Checks& checks, const std::string& path, const std::string& point) const;
};

// Reads model.elastic_bodies; `rigid_bodies`: the rigid bodies' names (clamps name them, and the
// two kinds share one name space), by body index.
std::vector<ElasticBodySpec> BuildElasticBodies(const interface::Checks& checks, const scenario::Model& model,
                                                const std::vector<std::string>& rigid_bodies);

}  // namespace cosim::smooth
