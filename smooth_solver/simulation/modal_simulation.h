#pragma once
// A MODES analysis (numerics.smooth.analysis: MODES): the linear modes of the constrained
// system about its steady state in a frame spinning at Ω (analysis/rotating_frame), for Ω over
// the "time" span — a rotor's fan plot. History columns: mode<k>_frequency [rad/s] per speed;
// modes.csv: every mode with its damping ratio, frequency per revolution and the shares of its
// kinetic energy in point motion along the spin axis (flap), tangential (lag) and radial, and in
// the nodes' twist about the radial direction (torsion).
#include <memory>
#include <vector>

#include "interface/run/run_driver.h"
#include "interface/run/run_output.h"
#include "smooth_solver/analysis/rotating_frame.h"
#include "smooth_solver/model/multibody_model.h"

namespace cosim::smooth {

class ModalSimulation : public interface::Simulation {
 public:
  explicit ModalSimulation(const interface::ScenarioFile& file);
  std::vector<std::string> ProbeNames() const override;
  void Probe(std::vector<double>* values) const override;
  void Step(double t, double h) override;
  void FillSummary(run::RunSummary* summary) const override;
  void BeginOutput(const std::string& folder) override;
  void EndOutput() override;

  struct Classified {
    Mode mode;
    // Shares of the mode's kinetic energy: node points along the axis, tangential and radial,
    // and the nodes' turn about the radial direction (Classify).
    double flap = 0.0, lag = 0.0, radial = 0.0, torsion = 0.0;
  };
  const std::vector<Classified>& modes() const { return modes_; }

 private:
  void Solve(double omega);
  Classified Classify(const Eigen::VectorXd& q, const Mode& mode) const;
  void WritePending();  // the solved speeds' modes into modes.csv, once it is open
  MultibodyModel model_;
  std::unique_ptr<MultibodySystem> system_;
  SystemData data_;  // the system's changing state (the rotors' inflow at the steady states)
  scenario::Numerics numerics_;
  Eigen::Vector3d axis_, origin_;
  int count_ = 10, ramp_steps_ = 1;
  Eigen::VectorXd q_;
  double omega_ = 0.0;
  std::vector<Classified> modes_;
  std::vector<std::vector<Classified>> pending_;  // per speed, until modes.csv is open
  std::vector<double> pending_speed_;
  std::unique_ptr<interface::OutputFile> csv_;
  long newton_total_ = 0;
  int solves_ = 0;
};

}  // namespace cosim::smooth
