#pragma once
// smooth_solver as the coordinator of a coupled run (a scenario with coupling.interface_nodes):
// the multibody model with its coincidence rows, one channel per contact process (it connects
// to coupling.processes[].endpoint), and the Coordinator stepping them together. Probes and
// the summary are the smooth model's, plus the coupling iteration statistics; `Finish` ends
// the contact processes' runs with this run's outcome.
#include <memory>
#include <string>
#include <vector>

#include "interface/run/run_output.h"
#include "interface/scenario/coupling_plan.h"
#include "smooth_solver/coupling/coordinator.h"
#include "smooth_solver/simulation/multibody_simulation.h"

namespace zmq {
class context_t;
}

namespace cosim::smooth {

class CoupledSmoothSimulation : public interface::Simulation {
 public:
  // Throws InputError for settings this build cannot run (an integrator other than CGALPHA,
  // missing endpoints, an interface node in no process) naming the field.
  explicit CoupledSmoothSimulation(const interface::ScenarioFile& file);
  ~CoupledSmoothSimulation() override;

  std::vector<std::string> ProbeNames() const override { return simulation_->ProbeNames(); }
  void Probe(std::vector<double>* values) const override { simulation_->Probe(values); }
  void Visual(interface::VisualFrame* frame) const override { simulation_->Visual(frame); }
  void Step(double t, double h) override;
  void FillSummary(run::RunSummary* summary) const override;
  void Finish(ExitCode code, const std::string& reason) override;
  // coupling.csv: every coupling iteration of every step (step, iteration, reaction residual,
  // displacement change, relaxation factor), written as the steps go.
  void BeginOutput(const std::string& folder) override;
  void EndOutput() override;

 private:
  std::vector<Coordinator::MovingObstacle> MovingObstacles(const interface::ScenarioFile& file,
                                                           const interface::ContactProcessPlan& process) const;
  std::unique_ptr<MultibodySimulation> simulation_;
  std::unique_ptr<zmq::context_t> context_;
  std::vector<std::unique_ptr<interface::Channel>> channels_;  // one per contact process
  std::unique_ptr<Coordinator> coordinator_;
  interface::IterationCounter coupling_;
  void WriteIterations();  // the coordinator's records of the last step, to coupling.csv
  std::unique_ptr<interface::OutputFile> iterations_;
  bool handshaken_ = false;
  std::string scenario_name_;
  double start_time_ = 0.0, step_ = 0.0;
  // numerics.adaptive: error-controlled coupled steps up to the history's next row time, each
  // the coordinator's (a Stepper whose checkpoint is the coordinator's step start).
  void StepAdaptively(double until);
  class CoupledStepper;
  std::unique_ptr<CoupledStepper> stepper_;
  interface::TimeSpan span_;
  int every_ = 1;
};

}  // namespace cosim::smooth
