#pragma once
// What a contact process must do for the coupling server (contact_server.h), whatever its
// method: Moreau–Jean with an LCP (ContactSimulation) or a penalty law (PenaltySimulation).
// It is also a run-contract Simulation (probes, summary), so the same program runs standalone.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "interface/run/run_driver.h"
#include "nonsmooth_solver/model/contact_model.h"
#include "state.pb.h"

namespace cosim::nonsmooth {

class ContactStepper : public interface::Simulation {
 public:
  // One step of the method (Advance), then the checks every contact method's result must pass:
  // a finite state (StepTentatively), and no contact deeper through its obstacle than
  // numerics.nonsmooth.max_penetration (CheckAccepted). Throws NumericalError (exit 3) naming
  // the node or the contact; the state is then the failed step's. A coupled run checks the
  // depth only of the step the coordinator accepts: a coupling iteration's tentative step may
  // go deep under a reaction that the iteration then corrects.
  void Step(double t, double h) final;
  void StepTentatively(double t, double h);
  void CheckAccepted(double t) const;
  virtual const ContactModel& model() const = 0;
  // Checkpoint of the step's start, and back to it (every coupling iteration restarts there;
  // a rejected step too): the nodes' state. Not the ContactData: the frames are the step's
  // input, as the external forces are, set by the coupling server for each try.
  virtual void SaveStart() = 0;
  virtual void RestoreStart() = 0;
  // The driven obstacles' frames, which the coupling server sets (model().driven_frames of them).
  virtual ContactData* mutable_data() = 0;
  virtual const ContactData& data() const = 0;
  virtual double time() const = 0;  // of the state [s]
  // Force per node [N] (3 × nodes, model order), constant over the next steps.
  virtual void SetExternalForces(const Eigen::VectorXd& forces) = 0;
  // Starts node `node` (model order) at x [m] with velocity v [m/s] instead of the scenario's
  // (a settled start's Hello.node_positions); before the start checkpoint.
  virtual void StartNodeAt(int node, const Eigen::Vector3d& x, const Eigen::Vector3d& v) = 0;
  virtual const Eigen::VectorXd& positions() const = 0;   // 3 per node
  virtual const Eigen::VectorXd& velocities() const = 0;  // 3 per node
  // Whether `node`'s velocity jumped in the last step (an impulsive contact reaction: an impact
  // or a persisting closed contact of the nonsmooth model). Sent as Kinematics.in_contact: the
  // coordinator restarts the smooth integrator's acceleration history after an impact.
  virtual bool Impact(int node) const = 0;
  virtual std::string SolverName() const = 0;  // for the Welcome

  // Interface Jacobians (protocol version 3, docs/protocol.md): a method that can take the
  // coordinator's linearised smooth side as an implicit force law on its nodes and report its
  // nodes' sensitivities says so (the Welcome's interface_jacobians) and is switched on once.
  virtual bool SupportsInterfaceJacobians() const { return false; }
  virtual void EnableInterfaceJacobians() {}
  // The smooth side's linearisation for the next steps: `stiffness` 9 per node (row-major
  // ∂force/∂position, zero for a node without), `reference` 3 per node; empty: none.
  virtual void SetInterfaceStiffness(const Eigen::VectorXd& /*stiffness*/, const Eigen::VectorXd& /*reference*/) {}
  // After a step: the force held on each node (3 per node), and the sensitivities of the nodes'
  // end positions and velocities to a constant force on them (9 per node, row-major) at the
  // step's contact set. Null: the method has none (the external forces were held as given).
  virtual const Eigen::VectorXd* AppliedForces() const { return nullptr; }
  virtual bool Sensitivities(double /*h*/, Eigen::VectorXd* /*position*/, Eigen::VectorXd* /*velocity*/) const {
    return false;
  }
  virtual double Gap(int contact) const = 0;      // [m] at the current time
  virtual double GapRate(int contact) const = 0;  // [m/s] at the current time
  virtual double Impulse(int contact) const = 0;  // [N s] over the last step

  // The earliest time [s] from now at which one of the contacts could close at its present
  // rate: gap / closing speed over the open ones (+∞ if every open contact is opening or
  // still); 0 if a closed one (gap <= 0, or an impulse or force in the last step) moves along its
  // normal faster than `resting_speed` [m/s] (an impact or a rebound under way); closed ones
  // slower are resting and left out. Sent as Kinematics.time_to_contact: the coordinator's
  // adaptive step stops short of it (numerics.adaptive.resting_speed), and a step no contact
  // can reach may skip its confirming coupling iteration (free_flight_margin).
  double TimeToContact(double resting_speed) const;

  // The method's step from t to t + h (Moreau–Jean, the penalty law).
  virtual void Advance(double t, double h) = 0;

  // Saved states (numerics.initial_state; proto/state.proto ContactState). UseSavedState
  // remembers the scene's name and this process's ("" standalone) for the state this run will
  // write, and, if the scenario names an initial state, starts from it: standalone the file
  // itself, a coupled process NAME the file NAME/final_state.pb in the folder of the smooth
  // solver's state (where the run that wrote both put it). A state of another scene, process,
  // method, node set or time is refused (InputError naming numerics.initial_state). Returns
  // whether it started from one (then the attached obstacles keep the saved body-frame geometry).
  bool UseSavedState(const interface::ScenarioFile& file, const std::string& process);
  // The run's output folder: at its end final_state.pb there holds the last accepted state.
  void BeginOutput(const std::string& folder) override { output_folder_ = folder; }
  void EndOutput() override;
  // "moreau_jean" or "penalty": a saved state restarts its own method only.
  virtual std::string MethodName() const = 0;

  // The model's probes, from the state above (the same for every contact method).
  std::vector<std::string> ProbeNames() const override;
  void Probe(std::vector<double>* values) const override;
  // The contact nodes as vertices and each obstacle as a square patch around the nodes that can
  // touch it, `in_contact` = 1 on a node (and its plane) whose contact is closed or acted in
  // the last step (interface/visual).
  void Visual(interface::VisualFrame* frame) const override;

 protected:
  // Reads numerics.nonsmooth.max_penetration [m] of `file`, the depth through an obstacle after
  // an accepted step beyond which the step failed (CheckAccepted; every contact method).
  explicit ContactStepper(const interface::ScenarioFile& file);

  // The method's part of a saved state: time, nodes' q and v, impulses and its own memory (the
  // sizes are checked before ReadState).
  virtual void WriteState(state::ContactState* s) const = 0;
  virtual void ReadState(const state::ContactState& s) = 0;

 private:
  std::string scenario_name_, process_, output_folder_;
  double penetration_limit_ = 0.1;  // [m], numerics.nonsmooth.max_penetration
  bool stepping_ = false;           // a standalone step under way: its start is the state to save
};

}  // namespace cosim::nonsmooth
