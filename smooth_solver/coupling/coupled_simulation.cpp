#include "smooth_solver/coupling/coupled_simulation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <zmq.hpp>

#include "interface/base/errors.h"
#include "interface/scenario/checks.h"
#include "interface/scenario/coupling_plan.h"

namespace cosim::smooth {

namespace sc = scenario;

// The obstacles that `process`'s nodes touch and that are attached to a rigid body of the
// smooth model (a stop on a hub): their frames go to the process every iteration.
std::vector<Coordinator::MovingObstacle> CoupledSmoothSimulation::MovingObstacles(
    const interface::ScenarioFile& file, const interface::ContactProcessPlan& process) const {
  const sc::Model& model = file.proto().model();
  std::set<std::string> touched;
  for (const auto& node : model.contact_nodes()) {
    if (std::find(process.nodes.begin(), process.nodes.end(), node.name()) == process.nodes.end()) continue;
    for (const auto& c : node.contacts()) touched.insert(c.obstacle());
  }
  std::vector<Coordinator::MovingObstacle> out;
  const auto& bodies = simulation_->model().bodies;
  for (int i = 0; i < model.obstacles_size(); ++i) {
    const sc::Obstacle& o = model.obstacles(i);
    if (!o.has_attached_to_body() || o.attached_to_body() == "ground" || touched.count(o.name()) == 0) continue;
    int body = -1;
    std::string known;
    for (size_t b = 0; b < bodies.size(); ++b) {
      if (bodies[b].name == o.attached_to_body()) body = static_cast<int>(b);
      known += (known.empty() ? "" : ", ") + bodies[b].name;
    }
    if (body < 0) {
      file.Fail(interface::ElementPath("model.obstacles", i) + ".attached_to_body",
                "no rigid body named '" + o.attached_to_body() + "'; known: " + known);
    }
    out.push_back(Coordinator::MovingObstacle{o.name(), body});
  }
  return out;
}

namespace {

// coupling.iteration, checked: the coordinator's settings.
CouplingSettings ReadCouplingSettings(const interface::Checks& checks, const interface::ScenarioFile& file) {
  const sc::Coupling::CouplingIteration& it = file.proto().coupling().iteration();
  CouplingSettings settings;
  if (it.max_iterations() < 1) {
    checks.Fail("coupling.iteration.max_iterations", "must be >= 1, got " + std::to_string(it.max_iterations()));
  }
  settings.max_iterations = it.max_iterations();
  settings.displacement_tolerance =
      checks.Positive("coupling.iteration.displacement_tolerance", true, it.displacement_tolerance(), "m");
  settings.reaction_tolerance =
      checks.Positive("coupling.iteration.reaction_tolerance", true, it.reaction_tolerance(), "dimensionless");
  switch (it.relaxation()) {
    case sc::Coupling::CouplingIteration::CONSTANT:
      settings.relaxation = interface::Relaxation::Method::kConstant;
      break;
    case sc::Coupling::CouplingIteration::AITKEN:
      settings.relaxation = interface::Relaxation::Method::kAitken;
      break;
    case sc::Coupling::CouplingIteration::IQN_ILS:
      settings.relaxation = interface::Relaxation::Method::kIqnIls;
      break;
    default:
      checks.Fail("coupling.iteration.relaxation", "expected CONSTANT, AITKEN or IQN_ILS");
  }
  settings.relaxation_factor =
      checks.InRange("coupling.iteration.relaxation_factor", true, it.relaxation_factor(), 0.0, 2.0);
  if (it.reuse_steps() < 0) {
    checks.Fail("coupling.iteration.reuse_steps", "must be >= 0, got " + std::to_string(it.reuse_steps()));
  }
  settings.reuse_steps = it.reuse_steps();
  if (it.reaction() != sc::Coupling::CouplingIteration::END_OF_STEP &&
      it.reaction() != sc::Coupling::CouplingIteration::STEP_AVERAGE) {
    checks.Fail("coupling.iteration.reaction", "expected END_OF_STEP or STEP_AVERAGE");
  }
  settings.step_average_reaction = it.reaction() == sc::Coupling::CouplingIteration::STEP_AVERAGE;
  // Unset, the reaction is the contact program's: STEP_AVERAGE when every process is a compliant
  // penalty_solver (END_OF_STEP lags its contact force and gains energy: proto/scenario/coupling.proto), so
  // that swapping the contact solver is the program's field and its contact stiffness.
  const auto& processes = file.proto().coupling().processes();
  if (!it.has_reaction() && !processes.empty() &&
      std::all_of(processes.begin(), processes.end(),
                  [](const sc::Coupling::ContactProcess& p) { return p.program() == "penalty_solver"; })) {
    settings.step_average_reaction = true;
  }
  if (it.on_max_iterations() != sc::Coupling::CouplingIteration::STOP &&
      it.on_max_iterations() != sc::Coupling::CouplingIteration::ACCEPT_AND_MARK) {
    checks.Fail("coupling.iteration.on_max_iterations", "expected STOP or ACCEPT_AND_MARK");
  }
  settings.stop_at_max_iterations = it.on_max_iterations() == sc::Coupling::CouplingIteration::STOP;
  settings.restart_at_impact = it.restart_at_impact();
  settings.warm_start = it.warm_start();
  settings.interface_jacobians = it.interface_jacobians();
  settings.accept_agreeing_linearisation = it.accept_agreeing_linearisation();
  settings.free_flight_margin = it.free_flight_margin();
  settings.settled_start = file.proto().numerics().smooth().settle();
  if (!(settings.free_flight_margin >= 0.0) || !std::isfinite(settings.free_flight_margin)) {
    checks.Fail("coupling.iteration.free_flight_margin",
                "must be a finite number of steps >= 0 (0: always iterate), got " +
                    interface::FormatNumber(settings.free_flight_margin));
  }
  if (!settings.restart_at_impact) {
    // Without the restart only a compliant tie can carry a node's velocity jump to the smooth model.
    const auto& nodes = file.proto().coupling().interface_nodes();
    for (int i = 0; i < nodes.size(); ++i) {
      if (nodes[i].regularization() <= 0.0) {
        checks.Fail("coupling.iteration.restart_at_impact",
                    "false needs every interface node regularised (Tikhonov c > 0); coupling.interface_nodes[" +
                        std::to_string(i) + "] ('" + nodes[i].contact_node() + "') is rigid");
        break;
      }
    }
  }

  return settings;
}

// A node of a beam or an elastic body tied rigidly (c = 0) to a contact node that has obstacles to
// meet: at an impact the contact process's velocity jump would have to move that one node alone
// (the impact's restart projects only rigid bodies: Coordinator::Accept), and the next step's
// position projection diverges (|Φ| = inf; generated hingeless rotors with rigid ties on their
// pads, tests/data/rotors/). A compliant tie carries the jump into the elastic body over a few
// steps. Refused before the run, naming the tie.
void RequireCompliantTiesOnElasticNodesThatTouch(const interface::Checks& checks, const interface::ScenarioFile& file,
                                                 const MultibodySystem& sys) {
  const auto& nodes = file.proto().coupling().interface_nodes();
  for (int i = 0; i < nodes.size() && i < static_cast<int>(sys.interface_points.size()); ++i) {
    const InterfacePoint& p = sys.interface_points[static_cast<size_t>(i)];
    if (!p.elastic || p.regularization > 0.0) continue;
    for (const auto& node : file.proto().model().contact_nodes()) {
      if (node.name() != p.contact_node || node.contacts_size() == 0) continue;
      checks.Fail(interface::ElementPath("coupling.interface_nodes", i) + ".regularization",
                  "0 (a rigid tie) on an elastic node ('" + nodes[i].body() + "'), whose contact node '" +
                      p.contact_node +
                      "' meets obstacles: a rigid tie cannot pass an impact's velocity jump into an elastic "
                      "body; give a compliance c > 0 (the Puma scenes' 5e-9 m/N)");
    }
  }
}

}  // namespace

// The coordinator's coupled step as the adaptive controller's Stepper: a try is Coordinator::Try
// (which saves the step's start: the one checkpoint), a rejection Coordinator::Reject (which
// restores it), an acceptance Coordinator::Accept with the step's coupling iterations recorded.
class CoupledSmoothSimulation::CoupledStepper final : public Stepper {
 public:
  explicit CoupledStepper(CoupledSmoothSimulation* run) : run_(run) {}
  [[nodiscard]] StepAttempt TryStep(double t, double h) override {
    last_ = run_->coordinator_->Try(t, h);
    StepAttempt attempt;
    attempt.iterations = run_->coordinator_->last_newton_iterations();
    attempt.failed = !last_.converged();  // (an unconverged step is rejected as a failed one)
    attempt.impact = last_.impact;        // a contact that closed in the step (a resting one is smooth motion)
    attempt.time_to_contact = last_.time_to_contact;
    return attempt;
  }
  void Accept(double t, double h) override {
    run_->coordinator_->Accept(t, h);
    run_->WriteIterations();
    run_->coupling_.Add(last_.iterations);
  }
  void Reject() override { run_->coordinator_->Reject(); }
  [[nodiscard]] std::string WhyFailed() const override { return run_->coordinator_->Describe(last_); }
  const CgAlpha& integrator() const override { return *run_->simulation_->cgalpha(); }
  const CgAlpha::Checkpoint& start() const override { return run_->coordinator_->start(); }

 private:
  CoupledSmoothSimulation* run_;
  Coordinator::Attempt last_;
};

CoupledSmoothSimulation::CoupledSmoothSimulation(const interface::ScenarioFile& file)
    : simulation_(std::make_unique<MultibodySimulation>(file, /*coupled=*/true)),
      context_(std::make_unique<zmq::context_t>()),
      scenario_name_(file.proto().name()) {
  const interface::Checks checks(file);
  if (!simulation_->integrator().capabilities().checkpoints) {
    checks.Fail("numerics.smooth.integrator",
                "a coupled run needs CGALPHA (its steps are repeated per coupling "
                "iteration from a checkpoint)");
  }
  const interface::ChannelTiming timing = interface::ReadChannelTiming(file);
  const interface::CurveKeys keys = interface::CurveKeysFromEnvironment();
  std::vector<Coordinator::Peer> peers;
  const MultibodySystem& sys = simulation_->system();
  std::vector<bool> served(sys.interface_points.size(), false);
  for (const interface::ContactProcessPlan& process : interface::ReadCouplingPlan(file)) {
    const std::string path = interface::ElementPath("coupling.processes", process.index);
    checks.Require(path + ".endpoint", !process.endpoint.empty(),
                   "an endpoint (ipc://path or tcp://host:port; scripts/cosim run sets one)");
    interface::ChannelOptions options;
    options.endpoint = process.endpoint;
    options.bind = false;
    options.self = "smooth_solver";
    options.peer = process.name;
    options.timeout = timing.timeout;
    options.heartbeat = timing.heartbeat;
    options.keys = keys;
    // The interface points whose contact node this process integrates, in interface order.
    std::vector<int> points;
    for (size_t k = 0; k < sys.interface_points.size(); ++k) {
      for (const std::string& node : process.nodes) {
        if (node == sys.interface_points[k].contact_node) {
          points.push_back(static_cast<int>(k));
          served[k] = true;
        }
      }
    }
    if (points.empty()) continue;  // a process without interface nodes has nothing to exchange
    channels_.push_back(std::make_unique<interface::Channel>(context_.get(), options));
    peers.push_back(Coordinator::Peer{channels_.back().get(), points, MovingObstacles(file, process)});
  }
  for (size_t k = 0; k < served.size(); ++k) {
    if (!served[k]) {
      checks.Fail(interface::ElementPath("coupling.interface_nodes", static_cast<int>(k)) + ".contact_node",
                  "contact node '" + sys.interface_points[k].contact_node + "' is in no contact process");
    }
  }

  const CouplingSettings settings = ReadCouplingSettings(checks, file);
  RequireCompliantTiesOnElasticNodesThatTouch(checks, file, sys);
  coordinator_ = std::make_unique<Coordinator>(sys, simulation_->mutable_data(), simulation_->cgalpha(),
                                               std::move(peers), settings);
  if (const state::CoordinatorMemory* saved = simulation_->saved_coordinator()) {
    const std::string wrong = coordinator_->ReadMemory(*saved);
    if (!wrong.empty()) checks.Fail("numerics.initial_state", wrong + ": expected a state of this scene");
  }
  start_time_ = file.proto().numerics().start_time();
  step_ = file.proto().numerics().step();
  span_ = interface::ValidateTimeSpan(file);
  every_ = file.proto().output().has_every() ? std::max(1, file.proto().output().every()) : 1;
  stepper_ = std::make_unique<CoupledStepper>(this);
}

CoupledSmoothSimulation::~CoupledSmoothSimulation() = default;

void CoupledSmoothSimulation::Step(double t, double h) {
  if (!handshaken_) {
    coordinator_->Handshake(scenario_name_, start_time_, step_);
    handshaken_ = true;
  }
  if (simulation_->adaptive()) {
    StepAdaptively(t + h);
    return;
  }
  int iterations = 0;
  try {
    iterations = coordinator_->Step(t, h);
  } catch (const Error&) {
    try {
      WriteIterations();  // the failed step's iterations say why it failed
    } catch (const Error&) {
      // A failed write is reported by EndOutput; the step's own failure goes on up.
    }
    throw;
  }
  WriteIterations();
  coupling_.Add(iterations);
  simulation_->Record(t + h, coordinator_->last_newton_iterations());
}

void CoupledSmoothSimulation::StepAdaptively(double until) {
  // The steps land on the history's next row time at or after `until` (the run driver writes a
  // row every output.every grid steps and at the end): both sides' rows are then states at
  // that time, not interpolations across the contact processes' velocity jumps.
  const long long k = std::llround((until - span_.start) / span_.step);
  const long long row = std::min(span_.steps, (k + every_ - 1) / every_ * every_);
  const double target = span_.TimeAt(row);
  simulation_->Advance(target, *stepper_);
}

void CoupledSmoothSimulation::FillSummary(run::RunSummary* summary) const {
  simulation_->FillSummary(summary);
  coupling_.Fill(summary->mutable_coupling_iterations());
  summary->mutable_counters()->insert({"coupling_steps_marked", static_cast<double>(coordinator_->marked_steps())});
  summary->mutable_counters()->insert({"coupling_steps_retried", static_cast<double>(coordinator_->retried_steps())});
  summary->mutable_counters()->insert(
      {"coupling_steps_at_roundoff", static_cast<double>(coordinator_->roundoff_steps())});
  summary->mutable_counters()->insert(
      {"coupling_free_flight_steps", static_cast<double>(coordinator_->free_flight_steps())});
  summary->mutable_counters()->insert({"coupling_backtracks", static_cast<double>(coordinator_->backtracks())});
  summary->mutable_counters()->insert(
      {"coupling_linearisation_fallbacks", static_cast<double>(coordinator_->linearisation_fallbacks())});
  summary->mutable_counters()->insert({"coupling_impacts_held", static_cast<double>(coordinator_->impacts_held())});
  summary->mutable_counters()->insert(
      {"coupling_steps_on_linearisation", static_cast<double>(coordinator_->linearisation_accepted())});
  summary->mutable_counters()->insert(
      {"coupling_interface_jacobians", coordinator_->interface_jacobians() ? 1.0 : 0.0});
}

void CoupledSmoothSimulation::Finish(ExitCode code, const std::string& reason) {
  if (code == ExitCode::kPeerFailure) return;  // the contact process is gone
  if (code == ExitCode::kBadInput) {
    // A contact process broke the protocol (this side's input was checked before the run):
    // tell the peers that can still listen, without waiting for answers nor handshaking.
    if (handshaken_) coordinator_->Shutdown(static_cast<int>(code), reason, /*wait_for_replies=*/false);
    return;
  }
  if (!handshaken_) coordinator_->Handshake(scenario_name_, start_time_, step_);
  coordinator_->Shutdown(static_cast<int>(code), reason);
}

void CoupledSmoothSimulation::BeginOutput(const std::string& folder) {
  simulation_->BeginOutput(folder);  // final_state.pb: the smooth side's state (each contact process saves its own)
  iterations_ = std::make_unique<interface::OutputFile>(folder + "/coupling.csv");
  std::fprintf(iterations_->get(), "step,iteration,reaction_residual,displacement_change,relaxation_factor\n");
  iterations_->EndRow();
}

void CoupledSmoothSimulation::WriteIterations() {
  if (iterations_ == nullptr) return;
  for (const CouplingIterationRecord& r : coordinator_->log()) {
    std::fprintf(iterations_->get(), "%lld,%d,%.17g,%.17g,%.17g\n", r.step, r.iteration, r.reaction_residual,
                 r.displacement_change, r.relaxation_factor);
  }
  iterations_->EndRow();
}

void CoupledSmoothSimulation::EndOutput() {
  if (iterations_ != nullptr && !iterations_->Flush()) throw InputError(iterations_->error() + " (is the disk full?)");
  simulation_->WriteFinalState(
      [this](state::SmoothState* saved) { coordinator_->WriteMemory(saved->mutable_coordinator()); });
}

}  // namespace cosim::smooth
