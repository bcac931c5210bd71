#pragma once
// A contact process of a coupled run inside the run driver's time loop (nonsmooth_solver
// SCENARIO --process NAME): it binds its endpoint (coupling.processes[NAME].endpoint), answers
// the coordinator's handshake, serves each step until the coordinator accepts it, and answers
// the coordinator's Shutdown at the end. Its probes, history and summary are those of the
// standalone contact process, for the accepted steps.
#include <memory>
#include <string>

#include "nonsmooth_solver/coupling/contact_server.h"

namespace zmq {
class context_t;
}

namespace cosim::nonsmooth {

class ServedContactSimulation : public interface::Simulation {
 public:
  // Throws InputError for an unknown process, a missing endpoint, or a scenario this build
  // cannot serve (several contact processes).
  ServedContactSimulation(const interface::ScenarioFile& file, const std::string& process);
  ~ServedContactSimulation() override;

  std::vector<std::string> ProbeNames() const override { return simulation_->ProbeNames(); }
  void Probe(std::vector<double>* values) const override { simulation_->Probe(values); }
  void Step(double t, double h) override;
  void FillSummary(run::RunSummary* summary) const override;
  void Finish(ExitCode code, const std::string& reason) override;

 private:
  std::unique_ptr<ContactSimulation> simulation_;
  std::unique_ptr<zmq::context_t> context_;
  std::unique_ptr<interface::Channel> channel_;
  std::unique_ptr<ContactServer> server_;
  int64_t step_ = 0;
  bool handshaken_ = false;
};

}  // namespace cosim::nonsmooth
