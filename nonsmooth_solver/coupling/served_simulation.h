#pragma once
// A contact process of a coupled run inside the run driver's time loop (nonsmooth_solver
// SCENARIO --process NAME): it binds its endpoint (coupling.processes[NAME].endpoint), answers
// the coordinator's handshake, serves each step until the coordinator accepts it, and answers
// the coordinator's Shutdown at the end. Its probes, history and summary are those of the
// standalone contact process, for the accepted steps. The contact method is the program's:
// `make` builds its ContactStepper for this process's nodes, or for every node when given
// nullptr (a standalone run) (Moreau–Jean in nonsmooth_solver, the penalty law in
// penalty_solver).
#include <functional>
#include <memory>
#include <set>
#include <string>

#include "nonsmooth_solver/coupling/contact_server.h"

namespace zmq {
class context_t;
}

namespace cosim::nonsmooth {

class ServedContactSimulation : public interface::Simulation {
 public:
  using StepperFactory = std::function<std::unique_ptr<ContactStepper>(const interface::ScenarioFile&,
                                                                       const std::set<std::string>* nodes)>;
  // Throws InputError for an unknown process or a missing endpoint.
  ServedContactSimulation(const interface::ScenarioFile& file, const std::string& process, const StepperFactory& make);
  ~ServedContactSimulation() override;

  std::vector<std::string> ProbeNames() const override { return simulation_->ProbeNames(); }
  void Probe(std::vector<double>* values) const override { simulation_->Probe(values); }
  void Visual(interface::VisualFrame* frame) const override { simulation_->Visual(frame); }
  // The handshake, before the first row: the Hello may move the nodes (a settled start) and
  // sets the attached obstacles' frames, which the first row's gaps need.
  void Start() override;
  void Step(double t, double h) override;
  void FillSummary(run::RunSummary* summary) const override;
  void Finish(ExitCode code, const std::string& reason) override;
  // final_state.pb in this process's folder: its last accepted state (ContactState).
  void BeginOutput(const std::string& folder) override { simulation_->BeginOutput(folder); }
  void EndOutput() override;

 private:
  std::unique_ptr<ContactStepper> simulation_;
  std::unique_ptr<zmq::context_t> context_;
  std::unique_ptr<interface::Channel> channel_;
  std::unique_ptr<ContactServer> server_;
  int64_t step_ = 0;
  bool handshaken_ = false;
  bool adaptive_ = false;  // numerics.adaptive: the coordinator's steps (ServeUntil)
};

// main() of a contact program: standalone (a scene of contact nodes only) it runs `make`'s
// stepper over all nodes under the run contract; with --process NAME it serves that contact
// process of a coupled run. A coupled scene without --process is refused (exit 2).
int RunContactProgram(const std::string& program, int argc, char** argv,
                      const ServedContactSimulation::StepperFactory& make);

}  // namespace cosim::nonsmooth
