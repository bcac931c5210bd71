#pragma once
// A standalone smooth-solver run: model, natural-coordinate system, consistent initial
// state, CGα, and the probes, behind the run contract's Simulation interface.
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>

#include "interface/run/run_driver.h"
#include "interface/scenario/checks.h"
#include "smooth_solver/analysis/rotating_frame.h"
#include "smooth_solver/integrator/cgalpha.h"
#include "smooth_solver/integrator/ida_reference.h"
#include "smooth_solver/integrator/initial_conditions.h"
#include "smooth_solver/integrator/stepper.h"
#include "smooth_solver/simulation/adaptive_step.h"
#include "smooth_solver/simulation/node_rest.h"
#include "smooth_solver/simulation/smooth_probes.h"
#include "smooth_solver/simulation/visual_scene.h"
#include "smooth_solver/simulation/watchdog.h"
#include "state.pb.h"

namespace cosim::smooth {

class MultibodySimulation : public interface::Simulation {
 public:
  // `coupled`: the coordinator of a coupled run builds it (interface nodes allowed).
  explicit MultibodySimulation(const interface::ScenarioFile& file, bool coupled = false);

  std::vector<std::string> ProbeNames() const override;
  void Probe(std::vector<double>* values) const override;
  void Visual(interface::VisualFrame* frame) const override;
  void Step(double t, double h) override;
  void FillSummary(run::RunSummary* summary) const override;
  // final_state.pb in the output folder at the end of the run (its last accepted state):
  // numerics.initial_state of a later run starts from it.
  void BeginOutput(const std::string& folder) override;
  void EndOutput() override { WriteFinalState({}); }
  // final_state.pb with what `extend` adds to it (a coupled run: its coordinator's memory).
  void WriteFinalState(const std::function<void(state::SmoothState*)>& extend);
  // A restart that continued CGα's history: the coordinator's memory saved with it (nullptr
  // otherwise: the coupling starts afresh with CGα).
  const state::CoordinatorMemory* saved_coordinator() const {
    return saved_coordinator_ ? &*saved_coordinator_ : nullptr;
  }

  const MultibodySystem& system() const { return *system_; }
  // The run's changing state (the coordinator of a coupled run writes the imposed coordinates).
  const SystemData& data() const { return *data_; }
  SystemData* mutable_data() { return data_.get(); }
  const MultibodyModel& model() const { return model_; }
  const SmoothIntegrator& integrator() const { return *integrator_; }
  long long newton_iterations() const { return newton_.total(); }  // CGα, all steps so far
  // For the coordinator of a coupled run, which steps the integrator itself: the CGα
  // integrator (nullptr for the others), and the bookkeeping of an accepted step to t1.
  CgAlpha* cgalpha();
  void Record(double t1, int iterations);

  // Error-controlled steps of `stepper` (CGα's, or the coordinator's) from the integrator's time to
  // `target` (numerics.adaptive, adaptive_step.h): standalone the probes then read the state
  // interpolated at `target` if a step passed it, coupled runs land on it.
  void Advance(double target, Stepper& stepper);
  bool adaptive() const { return adaptive_.settings().on; }
  long ida_internal_steps() const { return ida_steps_; }
  double max_constraint_violation() const { return max_violation_; }  // over the accepted steps

 private:
  using Kind = SmoothProbe::Kind;
  using ProbeSpec = SmoothProbe;
  // What the integrators and the watchdog take from numerics.smooth.
  struct StepSettings {
    IdaSettings ida;
    CgAlphaSettings cgalpha;
    WatchdogSettings watchdog;  // but `energy`, which depends on the system
    scenario::Watchdog::EnergyCheck energy_check = scenario::Watchdog::AUTO;
  };
  // The construction's stages, in order: the elastic bodies (and the interface nodes on them),
  // the numerics (numerics_ and the step settings; numerics.adaptive into adaptive_), then the
  // system, its consistent initial state, the probes' references, the integrator and the
  // watchdog. Each throws InputError naming the field it refuses.
  std::vector<ElasticBodySpec> ElasticBodies(const interface::Checks& checks, const interface::ScenarioFile& file);
  StepSettings ReadStepSettings(const interface::Checks& checks, const interface::ScenarioFile& file, bool coupled);
  void BuildSystemAndState(const interface::Checks& checks, const interface::ScenarioFile& file, bool coupled,
                           const StepSettings& settings, std::vector<ElasticBodySpec>* elastic);
  void SetProbeReferences(const Eigen::VectorXd& q);
  // numerics.smooth.analysis STATIC: the equilibrium at t1 in place of a time step.
  void StaticStep(double t1);
  // numerics.smooth.settle: `initial` (closed) moved to the static equilibrium at start_time,
  // velocities and accelerations made consistent there. InputError for a run it does not fit,
  // NumericalError if there is no equilibrium.
  void Settle(const interface::Checks& checks, bool coupled, MultibodySystem* system, DaeState* initial);
  // Each interface point's imposed value where its node is, with the frame's rate and
  // acceleration there (at rest in the spinning frame).
  void ImposeNodes(const std::vector<RestingNode>& nodes, const SpinningFrame& spin);
  // The settle's rounds for the contact nodes of a coupled run, from the pinned solution `r`:
  // nodes that cannot rest where they start move (Settle, docs/design.md "Start, restart and
  // settled start of a coupled run"); `r` and `nodes` end where they rest.
  void SettleNodes(const MultibodySystem& system, const SpinningFrame& spin, EquilibriumOptions options,
                   std::vector<RestingNode>* nodes, EquilibriumResult* r);
  // StaticEquilibrium at the start time, or NumericalError naming the nodes it let move.
  EquilibriumResult SettleSolve(const MultibodySystem& system, const Eigen::VectorXd& q_guess,
                                const SpinningFrame& spin, const EquilibriumOptions& options);
  SpinningFrame SpinAtStart(const interface::Checks& checks, const MultibodySystem& system,
                            const DaeState& initial) const;
  int settle_iterations_ = 0;
  long long retried_steps_ = 0;  // fixed CGα steps redone as halves (or quarters): StepOrSplit
  int StepOrSplit(CgAlpha& cg, double t, double h, int depth);
  const CgAlpha* cgalpha_const() const { return cg_; }
  void UnwrapAngles(const Eigen::VectorXd& q);
  bool static_ = false;
  // A body's vector quantity (kind), in the probe's frame.
  Eigen::Vector3d BodyVector(const ProbeSpec& p) const;
  // Probe's pieces.
  double AeroProbe(const ProbeSpec& p, const DaeState& s) const;
  double JointCoordinateProbe(const ProbeSpec& p, const Eigen::VectorXd& q) const;
  double NodeDisplacementProbe(const ProbeSpec& p, const Eigen::VectorXd& q) const;

  MultibodyModel model_;
  std::unique_ptr<MultibodySystem> system_;  // the model: fixed once the start is made
  // The run's changing state, made from the system (MakeData) and passed to every evaluation.
  // (On the heap: the integrator and the coordinator hold its address.)
  std::unique_ptr<SystemData> data_;
  std::unique_ptr<SmoothIntegrator> integrator_;
  CgAlpha* cg_ = nullptr;                    // integrator_, if it is CGα
  std::unique_ptr<CgAlphaStepper> stepper_;  // its adaptive steps, standalone
  bool ida_ = false;
  long ida_steps_ = 0;
  std::vector<ProbeSpec> probes_;
  scenario::Numerics numerics_;
  InitialConditionReport initial_report_;
  interface::IterationCounter newton_;
  std::unique_ptr<Watchdog> watchdog_;
  long steps_ = 0;
  double time_ = 0.0;
  double last_step_ = 0.0;  // the last accepted step's length (saved with CGα's history)
  double max_violation_ = 0.0;
  // numerics.adaptive (CGα): the controller. time_ is the integrator's time, which may run ahead
  // of the output grid; the probes then read shown_, the state interpolated at probe_time_
  // between previous_ (at previous_time_, the last accepted step's start) and the integrator's.
  AdaptiveController adaptive_;
  void Interpolate(double t);
  double Violation(const Eigen::VectorXd& q) const;  // |Φ|∞ of the state the probes read
  double previous_time_ = 0.0, probe_time_ = 0.0;
  std::optional<state::CoordinatorMemory> saved_coordinator_;
  DaeState previous_, shown_;
  bool interpolated_ = false;
  // Revolute angles unwrapped across ±π: turns added to atan2 per joint.
  std::vector<double> angle_offset_, last_angle_;
  std::string output_folder_, scenario_name_;
  VisualSettings visual_;
  // The consistent initial configuration of the run (or of the run a restart continues) and its
  // time: the probes' reference, saved with the final state.
  Eigen::VectorXd reference_q_;
  double reference_time_ = 0.0;
};

}  // namespace cosim::smooth
