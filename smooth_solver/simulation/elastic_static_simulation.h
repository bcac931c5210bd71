#pragma once
// A STATIC analysis (numerics.smooth.analysis: STATIC): elastic bodies clamped to ground under
// node loads that grow linearly over the pseudo-time span; each step is one Newton solve
// from the previous equilibrium. The CGα paper's cantilever verification (Tables 1-2) is such
// a run.
#include <vector>

#include "interface/run/run_driver.h"
#include "smooth_solver/elastic/elastic_model.h"

namespace cosim::smooth {

class ElasticStaticSimulation : public interface::Simulation {
 public:
  explicit ElasticStaticSimulation(const interface::ScenarioFile& file);

  std::vector<std::string> ProbeNames() const override;
  void Probe(std::vector<double>* values) const override;
  void Step(double t, double h) override;
  void FillSummary(run::RunSummary* summary) const override;
  // Each body at its last equilibrium (as the dynamic run draws hex27 bodies; the frames were
  // empty, so a STATIC run's visual output showed nothing).
  void Visual(interface::VisualFrame* frame) const override;

 private:
  struct ProbeSpec {
    enum class Kind { kDisplacement, kEnergy, kForce, kMoment };
    std::string name;
    Kind kind = Kind::kDisplacement;
    int body = 0, node = 0, component = 0;
  };
  // Resultant force and moment the clamps exert on body b (about the clamped nodes' centroid).
  void Reaction(int b, Eigen::Vector3d* force, Eigen::Vector3d* moment) const;
  std::vector<ElasticBodySpec> bodies_;
  std::vector<std::vector<int>> fixed_;      // clamped nodes per body
  std::vector<Eigen::Matrix3Xd> positions_;  // current equilibrium per body
  std::vector<ProbeSpec> probes_;
  scenario::Numerics numerics_;
  double start_ = 0.0, end_ = 1.0;
  double tolerance_ = 1e-8;
  int max_iterations_ = 20;
  interface::IterationCounter newton_;
  double max_residual_ = 0.0;
};

}  // namespace cosim::smooth
