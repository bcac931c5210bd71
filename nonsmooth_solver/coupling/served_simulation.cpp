#include "nonsmooth_solver/coupling/served_simulation.h"

#include <cmath>
#include <set>
#include <zmq.hpp>

#include "interface/base/errors.h"
#include "interface/scenario/checks.h"
#include "interface/scenario/coupling_plan.h"

namespace cosim::nonsmooth {

ServedContactSimulation::ServedContactSimulation(const interface::ScenarioFile& file, const std::string& process,
                                                 const StepperFactory& make)
    : context_(std::make_unique<zmq::context_t>()) {
  const interface::Checks checks(file);
  const std::vector<interface::ContactProcessPlan> plan = interface::ReadCouplingPlan(file);
  const interface::ContactProcessPlan& p = interface::FindProcess(plan, process, file);
  // This process integrates its own contact nodes only (the others are other processes').
  const std::set<std::string> nodes(p.nodes.begin(), p.nodes.end());
  simulation_ = make(file, &nodes);
  checks.Require(interface::ElementPath("coupling.processes", p.index) + ".endpoint", !p.endpoint.empty(),
                 "an endpoint (ipc://path or tcp://host:port; scripts/cosim run sets one)");
  interface::ChannelOptions options;
  options.endpoint = p.endpoint;
  options.bind = true;
  options.self = process;
  options.peer = "smooth_solver";
  const interface::ChannelTiming timing = interface::ReadChannelTiming(file);
  options.timeout = timing.timeout;
  options.heartbeat = timing.heartbeat;
  options.keys = interface::CurveKeysFromEnvironment();
  channel_ = std::make_unique<interface::Channel>(context_.get(), options);
  server_ = std::make_unique<ContactServer>(simulation_.get(), channel_.get(), file.proto().name());
  if (simulation_->UseSavedState(file, process)) server_->keep_attached_geometry();
  adaptive_ = file.proto().numerics().adaptive().enabled();
  const double resting = file.proto().numerics().adaptive().resting_speed();
  if (!(resting >= 0.0) || !std::isfinite(resting)) {
    file.Fail("numerics.adaptive.resting_speed",
              "must be a finite speed >= 0 [m/s], got " + interface::FormatNumber(resting));
  }
  server_->set_resting_speed(resting);
}

ServedContactSimulation::~ServedContactSimulation() = default;

void ServedContactSimulation::Start() {
  server_->Handshake();
  handshaken_ = true;
}

void ServedContactSimulation::Step(double t, double h) {
  if (!handshaken_) Start();
  if (adaptive_) {
    // The coordinator's steps: error controlled, landing on every output time (the history's
    // rows), rejected and redone at will; this run's grid step only says how far to serve.
    server_->ServeUntil(t + h);
  } else {
    server_->ServeStep(step_, t, h);
  }
  ++step_;
}

void ServedContactSimulation::FillSummary(run::RunSummary* summary) const {
  simulation_->FillSummary(summary);
  summary->mutable_counters()->insert({"tentative_steps", static_cast<double>(server_->tentative_steps())});
  if (adaptive_) {
    summary->mutable_counters()->insert({"adaptive_accepted_steps", static_cast<double>(server_->accepted_steps())});
    summary->mutable_counters()->insert({"adaptive_rejected_steps", static_cast<double>(server_->rejected_steps())});
  }
}

void ServedContactSimulation::Finish(ExitCode code, const std::string& reason) {
  if (code == ExitCode::kOk) {
    server_->ServeShutdown();  // the coordinator's last word
    return;
  }
  if (code == ExitCode::kPeerFailure) return;  // the coordinator is gone or broke the protocol
  if (channel_->peer_stopped()) return;        // the coordinator ended the run: it knows
  // This side failed (its step or bad input): tell the coordinator, which is waiting.
  auto* stop = channel_->Outgoing(step_, 0).mutable_shutdown();
  stop->set_exit_code(static_cast<int>(code));
  stop->set_reason(reason);
  channel_->Send();
}

void ServedContactSimulation::EndOutput() {
  // A step the coordinator did not accept (the run failed in it) leaves a tentative state: the
  // saved one is the step's start, the last accepted.
  if (handshaken_ && simulation_->time() != server_->accepted_time()) simulation_->RestoreStart();
  simulation_->EndOutput();
}

int RunContactProgram(const std::string& program, int argc, char** argv,
                      const ServedContactSimulation::StepperFactory& make) {
  return interface::RunProgram(
      program, argc, argv,
      [&](const interface::ScenarioFile& file,
          const interface::CommandLine& cli) -> std::unique_ptr<interface::Simulation> {
        if (!cli.process.empty()) return std::make_unique<ServedContactSimulation>(file, cli.process, make);
        if (file.proto().coupling().interface_nodes_size() > 0) {
          file.Fail("coupling.interface_nodes",
                    "the contact nodes are tied to the smooth model: run the coupled scene with scripts/cosim run "
                    "(or " +
                        program + " --process NAME under a coordinator)");
        }
        if (file.proto().numerics().adaptive().enabled()) {
          file.Fail("numerics.adaptive",
                    "a contact-only scene takes fixed steps (the adaptive step is the smooth "
                    "solver's, standalone or as the coordinator of a coupled run); remove it");
        }
        std::unique_ptr<ContactStepper> stepper =
            make(file, nullptr);  // every node; obstacles on smooth bodies refused
        stepper->UseSavedState(file, "");
        return stepper;
      },
      interface::ScenarioView::kContactProcess);
}

}  // namespace cosim::nonsmooth
