#include "smooth_solver/simulation/elastic_static_simulation.h"

#include <Eigen/Geometry>

#include "smooth_solver/simulation/visual_scene.h"

namespace cosim::smooth {

using interface::Checks;
using interface::ElementPath;
namespace sc = cosim::scenario;

ElasticStaticSimulation::ElasticStaticSimulation(const interface::ScenarioFile& file) {
  const Checks checks(file);
  const sc::Model& model = file.proto().model();
  if (model.bodies_size() > 0 || model.joints_size() > 0 || model.forces_size() > 0) {
    checks.Fail("numerics.smooth.analysis",
                "STATIC analysis handles elastic bodies clamped to ground only; this "
                "scene has rigid bodies, joints or force elements (use DYNAMIC)");
  }
  if (model.elastic_bodies_size() == 0) checks.Fail("model.elastic_bodies", "a STATIC analysis needs an elastic body");
  bodies_ = BuildElasticBodies(checks, model, {});
  for (size_t b = 0; b < bodies_.size(); ++b) {
    std::vector<int> fixed;
    for (const auto& clamp : bodies_[b].clamps) fixed.insert(fixed.end(), clamp.nodes.begin(), clamp.nodes.end());
    if (fixed.empty()) {
      checks.Fail(ElementPath("model.elastic_bodies", static_cast<int>(b)) + ".clamps",
                  "an unclamped body has no static equilibrium; clamp a face or nodes to \"ground\"");
    }
    for (size_t l = 0; l < bodies_[b].loads.size(); ++l) {
      if (bodies_[b].loads[l].time_varying) {
        checks.Fail(
            ElementPath(ElementPath("model.elastic_bodies", static_cast<int>(b)) + ".loads", static_cast<int>(l)) +
                ".factor",
            "a time factor applies to DYNAMIC analyses; a STATIC analysis ramps the loads itself");
      }
    }
    fixed_.push_back(fixed);
    positions_.push_back(bodies_[b].body.mesh().nodes);
  }
  numerics_.CopyFrom(file.proto().numerics());
  interface::MaterializeDefaults(&numerics_);
  numerics_.clear_nonsmooth();
  start_ = numerics_.start_time();
  end_ = numerics_.end_time();
  tolerance_ = checks.Positive("numerics.smooth.newton_tolerance", true, numerics_.smooth().newton_tolerance(),
                               "relative to the largest force");
  if (numerics_.smooth().newton_max_iterations() < 1) {
    checks.Fail("numerics.smooth.newton_max_iterations", "must be >= 1");
  }
  max_iterations_ = numerics_.smooth().newton_max_iterations();

  interface::NameTable names(checks, "probe");
  const sc::Output& output = file.proto().output();
  for (int i = 0; i < output.probes_size(); ++i) {
    const sc::Probe& p = output.probes(i);
    const std::string path = ElementPath("output.probes", i);
    ProbeSpec spec;
    spec.name = names.Declare(path + ".name", p.has_name(), p.name());
    int body = -1;
    for (size_t b = 0; b < bodies_.size(); ++b) {
      if (bodies_[b].name == p.entity()) body = static_cast<int>(b);
    }
    if (body < 0) checks.Fail(path + ".entity", "no elastic body named '" + p.entity() + "'");
    spec.body = body;
    if (p.quantity() == sc::Probe::DISPLACEMENT) {
      checks.Require(path + ".point", p.has_point(), "a node index, \"tip_centre\" or \"root_centre\"");
      spec.node = bodies_[static_cast<size_t>(body)].FindPoint(checks, path + ".point", p.point());
      spec.component = interface::ProbeComponent(checks, path, p, true);
    } else if (p.quantity() == sc::Probe::STRAIN_ENERGY) {
      spec.kind = ProbeSpec::Kind::kEnergy;
      spec.component = interface::ProbeComponent(checks, path, p, false);
    } else if (p.quantity() == sc::Probe::REACTION_FORCE || p.quantity() == sc::Probe::REACTION_MOMENT) {
      spec.kind = p.quantity() == sc::Probe::REACTION_FORCE ? ProbeSpec::Kind::kForce : ProbeSpec::Kind::kMoment;
      spec.component = interface::ProbeComponent(checks, path, p, true);
    } else {
      checks.Fail(path + ".quantity",
                  "a STATIC analysis records DISPLACEMENT, STRAIN_ENERGY, REACTION_FORCE or "
                  "REACTION_MOMENT, got " +
                      sc::Probe::Quantity_Name(p.quantity()));
    }
    probes_.push_back(spec);
  }
}

std::vector<std::string> ElasticStaticSimulation::ProbeNames() const {
  std::vector<std::string> names;
  for (const auto& p : probes_) names.push_back(p.name);
  return names;
}

void ElasticStaticSimulation::Reaction(int b, Eigen::Vector3d* force, Eigen::Vector3d* moment) const {
  // At a held node the support supplies what the internal force needs: R_a = f_int,a.
  const ElasticBodySpec& spec = bodies_[static_cast<size_t>(b)];
  const Eigen::Matrix3Xd& x = positions_[static_cast<size_t>(b)];
  Eigen::VectorXd f_int;
  spec.body.Assemble(x, &f_int, nullptr);
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (int a : fixed_[static_cast<size_t>(b)]) centroid += spec.body.mesh().nodes.col(a);
  centroid /= static_cast<double>(fixed_[static_cast<size_t>(b)].size());
  force->setZero();
  moment->setZero();
  for (int a : fixed_[static_cast<size_t>(b)]) {
    const Eigen::Vector3d R = f_int.segment<3>(3 * a);
    *force += R;
    *moment += (x.col(a) - centroid).cross(R);
  }
}

void ElasticStaticSimulation::Probe(std::vector<double>* values) const {
  for (size_t i = 0; i < probes_.size(); ++i) {
    const ProbeSpec& p = probes_[i];
    const ElasticBodySpec& b = bodies_[static_cast<size_t>(p.body)];
    const Eigen::Matrix3Xd& x = positions_[static_cast<size_t>(p.body)];
    switch (p.kind) {
      case ProbeSpec::Kind::kDisplacement:
        (*values)[i] = interface::PickComponent(x.col(p.node) - b.body.mesh().nodes.col(p.node), p.component);
        break;
      case ProbeSpec::Kind::kEnergy:
        (*values)[i] = b.body.StrainEnergy(x);
        break;
      case ProbeSpec::Kind::kForce:
      case ProbeSpec::Kind::kMoment: {
        Eigen::Vector3d force, moment;
        Reaction(p.body, &force, &moment);
        (*values)[i] = interface::PickComponent(p.kind == ProbeSpec::Kind::kForce ? force : moment, p.component);
        break;
      }
    }
  }
}

void ElasticStaticSimulation::Step(double t, double h) {
  const double factor = (t + h - start_) / (end_ - start_);  // loads grow linearly to end_time
  for (size_t b = 0; b < bodies_.size(); ++b) {
    std::vector<std::pair<int, Eigen::Vector3d>> loads;
    for (const auto& load : bodies_[b].loads) loads.emplace_back(load.node, factor * load.force);
    const StaticResult r = SolveStatic(bodies_[b].body, fixed_[b], loads, tolerance_, max_iterations_, &positions_[b]);
    positions_[b] = bodies_[b].body.mesh().nodes + r.displacement;
    newton_.Add(r.iterations);
    max_residual_ = std::max(max_residual_, r.residual);
  }
}

void ElasticStaticSimulation::FillSummary(run::RunSummary* summary) const {
  summary->mutable_numerics()->CopyFrom(numerics_);
  newton_.Fill(summary->mutable_newton_iterations());
  auto& counters = *summary->mutable_counters();
  counters["elastic_bodies"] = static_cast<double>(bodies_.size());
  double nodes = 0, elements = 0;
  for (const auto& b : bodies_) {
    nodes += b.body.node_count();
    elements += static_cast<double>(b.body.mesh().elements.size());
  }
  counters["nodes"] = nodes;
  counters["elements"] = elements;
  counters["max_static_residual_N"] = max_residual_;
}

void ElasticStaticSimulation::Visual(interface::VisualFrame* frame) const {
  for (size_t b = 0; b < bodies_.size(); ++b) {
    DrawHex27Body(bodies_[b].body, bodies_[b].name, static_cast<int>(b), positions_[b], frame);
  }
}

}  // namespace cosim::smooth
