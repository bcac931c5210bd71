#include "smooth_solver/coupling/coordinator.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "interface/base/errors.h"
#include "interface/scenario/checks.h"
#include "smooth_solver/integrator/initial_conditions.h"

namespace cosim::smooth {

Coordinator::Coordinator(const MultibodySystem& system, SystemData* data, CgAlpha* integrator, std::vector<Peer> peers,
                         const CouplingSettings& settings)
    : system_(system),
      data_(data),
      integrator_(integrator),
      settings_(settings),
      link_(system, std::move(peers)),
      n_(3 * static_cast<int>(system.interface_points.size())),
      it_(static_cast<int>(system.interface_points.size())),
      memory_(static_cast<int>(system.interface_points.size())),
      rows_(data),
      reaction_(system, *integrator, settings.step_average_reaction),
      jacobian_method_(system, integrator, link_, reaction_, settings_, &it_, &memory_, &rows_),
      relaxation_method_(settings_, &it_, &rows_) {
  // Until the first step: where the points are, at rest.
  for (Eigen::Index v = 0; v < n_; ++v) it_.answers.position(v) = data->imposed[static_cast<size_t>(v)].value;
}

void Coordinator::RestartWithCouplingRowsFree(DaeState state, double t, const std::vector<int>& points) {
  std::vector<int> rows;
  for (int k : points) {
    for (int j = 0; j < 3; ++j) rows.push_back(system_.interface_points[static_cast<size_t>(k)].first_row + j);
  }
  ConsistentAccelerations(system_, *data_, t, &state, &rows);
  integrator_->Restart(state);
  // The freed rows' multipliers are 0 there, and a = q̈: their filtered multipliers too; the
  // others' are the state's.
  reaction_.StartFrom(state, &memory_);
}

void Coordinator::WriteMemory(state::CoordinatorMemory* out) const {
  memory_.Write(out);
  method_->WriteMemory(out);
}

std::string Coordinator::ReadMemory(const state::CoordinatorMemory& in) {
  if (std::string wrong = memory_.Read(in); !wrong.empty()) return wrong;
  // (Before the handshake the method is not chosen: a saved relaxation is the relaxation's.)
  if (std::string wrong = relaxation_method_.ReadMemory(in); !wrong.empty()) return wrong;
  memory_.GetSensitivities(&it_.answers.sensitivity);
  restored_ = true;
  return {};
}

void Coordinator::Handshake(const std::string& scenario_name, double start_time, double step) {
  // The start: accelerations with the coupling rows left out (free interface points, λ = 0),
  // a_0 = q̈_0 (a shifted start would impose end-of-step coordinates at the wrong time). A
  // settled start knows the nodes' motion (at rest, or turning with the rotor): its state, the
  // rows held, stands, and its multipliers are the first reactions the peers hold (without
  // them the blades sank 0.006° in the first steps before the reactions caught up).
  if (restored_) {
    // A restart that continues the run: CGα's history, the data (the imposed coordinates) and
    // this memory are the run's own at the saved step.
    it_.x = it_.answers.applied = memory_.accepted_x;
  } else if (settings_.settled_start) {
    // a_0 = q̈_0 as at a free start: the shifted start-up would take the first try's imposed
    // coordinates (end-of-step values) at t_0 + Δα h, and each try of the first step its own a_0.
    integrator_->Restart(integrator_->state());
    resting_at_start_ = true;  // (Impacts)
    reaction_.StartFrom(integrator_->state(), &memory_);
    it_.x = memory_.accepted_x = it_.answers.applied = memory_.lambda_start;
  } else {
    std::vector<int> every_point(system_.interface_points.size());
    for (size_t k = 0; k < every_point.size(); ++k) every_point[k] = static_cast<int>(k);
    RestartWithCouplingRowsFree(integrator_->state(), start_time, every_point);
  }
  const DaeState& start = integrator_->state();
  PeerLink::Hello hello{scenario_name, start_time, step};
  Eigen::VectorXd positions(n_), velocities(n_);
  if (!restored_) {  // (a continued run's imposed coordinates are its own, restored with the data)
    for (size_t k = 0; k < system_.interface_points.size(); ++k) {
      const LinearVector& point = system_.interface_points[k].point;
      const Eigen::Vector3d a = point.Rate(start.qddot);  // point acceleration
      for (int j = 0; j < 3; ++j) data_->imposed[3 * k + static_cast<size_t>(j)].acceleration = a(j);
    }
    // A settled start: where the settle left the nodes (it may move them). A free start: where
    // the tied points are and how they move in the consistent start, which the contact process
    // checks against its nodes' scenario state (Hello.settled).
    for (size_t k = 0; k < system_.interface_points.size(); ++k) {
      const LinearVector& point = system_.interface_points[k].point;
      const Eigen::Index o = 3 * static_cast<Eigen::Index>(k);
      positions.segment<3>(o) = point.Value(start.q);
      velocities.segment<3>(o) = point.Rate(start.qdot);
      if (!settings_.settled_start) continue;
      for (int j = 0; j < 3; ++j) {
        const ImposedCoordinate& c = data_->imposed[static_cast<size_t>(o + j)];
        positions(o + j) = c.value;
        velocities(o + j) = c.rate;
      }
    }
    hello.node_positions = &positions;
    hello.node_velocities = &velocities;
    hello.settled = settings_.settled_start;
  }
  const bool offered = link_.Handshake(hello, start);
  if (settings_.interface_jacobians && n_ > 0 && offered) method_ = &jacobian_method_;
  // The nodes' motion at the start (the first step's predicted positions). A free start's nodes
  // are where their points are (λ = 0); a settled start's where the settle left them, its
  // imposed coordinates: a point on a regularised tie is not its node, and the settled rod
  // resting on its stop had its node predicted cλ = 4.9e-7 m inside the stop (its point's
  // position) and its first step began from a pre-solve with the tie slack. A continued run
  // keeps its memory (overwritten here, a restart from the middle of a contact began from the
  // points' positions too).
  if (restored_) return;
  memory_.accepted_position = positions;
  memory_.accepted_velocity = velocities;
  for (size_t k = 0; k < system_.interface_points.size(); ++k) {
    memory_.accepted_acceleration.segment<3>(3 * static_cast<Eigen::Index>(k)) =
        system_.interface_points[k].point.Rate(start.qddot);
  }
}

int Coordinator::Step(double t, double h) { return StepOrSplit(t, h, 0); }

// A step the coupled solve cannot take (a CGα solve failed, or no convergence with
// stop_at_max_iterations) is rejected at every peer and redone as two halves, a half that fails
// as two quarters (StepStatus::kRetrySplits); only then does the run end, its message saying that smaller steps
// were tried. A fixed-step run's rows stay on its grid: the substeps end where the step ends.
int Coordinator::StepOrSplit(double t, double h, int depth) {
  const Attempt attempt = Try(t, h);
  if (attempt.converged() || (!attempt.failed() && !settings_.stop_at_max_iterations)) {
    if (!attempt.converged()) ++marked_;
    Accept(t, h);
    return attempt.iterations;
  }
  if (depth >= StepStatus::kRetrySplits) {
    std::string why = Describe(attempt);
    if (depth > 0) why = StepStatus::AfterRetries(why, 1 << depth, h, t);
    integrator_->Restore(start_);
    throw NumericalError(why);
  }
  Reject();
  ++retried_;
  const int first = StepOrSplit(t, 0.5 * h, depth + 1);
  return first + StepOrSplit(t + 0.5 * h, 0.5 * h, depth + 1);
}

std::string Coordinator::Describe(const Attempt& attempt) const {
  const std::string to = " the step to t = " + interface::FormatNumber(attempt.end_time) + " s";
  switch (attempt.outcome) {
    case Attempt::Outcome::kConverged:
      return "coupling: the step to t = " + interface::FormatNumber(attempt.end_time) + " s converged";
    case Attempt::Outcome::kNotConverged:
      return "coupling: no convergence in " + std::to_string(settings_.max_iterations) + " iterations at step " +
             std::to_string(step_) + " (t = " + interface::FormatNumber(attempt.end_time) + " s): reaction residual " +
             interface::FormatNumber(log_.back().reaction_residual) + " N, displacement change " +
             interface::FormatNumber(log_.back().displacement_change) + " m; " + CouplingState() +
             (interface_jacobians()
                  ? "; raise coupling.iteration.max_iterations"
                  : "; raise coupling.iteration.max_iterations, choose another relaxation, or shorten the step");
    case Attempt::Outcome::kSmoothFailed: {
      const std::string why = attempt.smooth.Describe(integrator_->settings());
      if (!attempt.with_answers) return why;
      // The smooth step could not take the contact processes' answers: say which.
      return "coupling iteration " + std::to_string(attempt.failed_iteration) + " of" + to +
             ": the smooth step with the contact processes' answers failed (" + CouplingState() + "): " + why;
    }
    case Attempt::Outcome::kReactionsNotFinite:
      return "coupling: the smooth model's reactions on the interface nodes are not finite after coupling iteration " +
             std::to_string(attempt.failed_iteration) + " of" + to;
  }
  return {};
}

std::string Coordinator::CouplingState() const {
  // Which interface nodes are in contact (closing in this step or resting), and where the two
  // sides disagree most: the coupling's side of a failed step.
  // A contact that opened in the step (a lift-off, a rebound) is named too: "none in contact"
  // at the step of a rebound read as if nothing had happened.
  const std::vector<bool>& contact = it_.answers.contact;
  const std::vector<bool>& was_contact = memory_.was_contact;
  std::string contacts;
  for (size_t k = 0; k < contact.size(); ++k) {
    if (!contact[k] && !was_contact[k]) continue;
    const char* what = !contact[k]      ? " (opening in this step)"
                       : was_contact[k] ? " (resting)"
                                        : " (closing in this step)";
    contacts +=
        (contacts.empty() ? "" : ", ") + std::string("'") + system_.interface_points[k].contact_node + "'" + what;
  }
  std::string worst;
  double largest = -1.0;
  const Eigen::VectorXd& held = method_->HeldForce();
  const Eigen::VectorXd& position = it_.answers.position;
  for (size_t k = 0; k < system_.interface_points.size(); ++k) {
    const Eigen::Index o = 3 * static_cast<Eigen::Index>(k);
    const double d = (it_.x_tilde.segment<3>(o) - held.segment<3>(o)).lpNorm<Eigen::Infinity>();
    if (d > largest) {
      largest = d;
      worst = "node '" + system_.interface_points[k].contact_node + "' (force " +
              interface::FormatNumber(it_.x_tilde.segment<3>(o).norm()) + " N, position " + "[" +
              interface::FormatNumber(position(o)) + ", " + interface::FormatNumber(position(o + 1)) + ", " +
              interface::FormatNumber(position(o + 2)) + "] m)";
    }
  }
  return "interface nodes in contact: " +
         (contacts.empty() ? std::string("none, in this step and the last") : contacts) +
         (worst.empty() ? "" : "; largest force mismatch " + interface::FormatNumber(largest) + " N at " + worst);
}

ReactionsToSend Coordinator::Sent() const {
  // (The stiffness and positions are the interface Jacobians' linearisation; with a relaxation
  // they are not sent.)
  return {it_.x, interface_jacobians(), jacobian_method_.stiffness(), jacobian_method_.linearised_at()};
}

void Coordinator::BeginStep(double t, double h, const DaeState& frames, double ahead) {
  link_.BeginStep(step_, t, h, Sent(), frames, ahead, Moved());
  moved_points_.clear();  // (told: the peers accepted the step with them)
  link_.Receive(step_, 0, interface_jacobians(), it_.x, &it_.answers);
}

void Coordinator::Exchange(int iteration, const DaeState& frames) {
  link_.Exchange(step_, iteration, Sent(), frames);
  link_.Receive(step_, iteration, interface_jacobians(), it_.x, &it_.answers);
}

StepStatus Coordinator::SolveStep(double t, double h, const DaeState* guess) {
  if (guess != nullptr && !iterate_solved_) guess = nullptr;  // (the step's predictor instead)
  const StepStatus status = integrator_->TryStep(t, h, guess, &rows_.motion());
  if (!status.ok()) return status;
  newton_ += status.iterations;
  iterate_ = integrator_->state();  // equal sizes: no allocation once warm
  iterate_solved_ = true;
  reaction_.FromSolve(integrator_->state().lambda, memory_, &it_.x_tilde);
  return status;
}

// The step's start saved, and the predictor: the reactions extrapolated linearly from the last
// two accepted steps (constant after a start or an impact), scaled to this step's length. With a
// stiff tie the first residual is the prediction error times the tie's gain, so this is worth an
// iteration per step.
void Coordinator::BeginTry(double h) {
  iterate_solved_ = false;
  log_.clear();  // this step's records (the capacity stays: no allocation once warm)
  integrator_->SaveTo(&start_);
  rows_.BeginStep(n_);
  method_->BeginStep();
  const double ratio = memory_.accepted_h > 0.0 ? h / memory_.accepted_h : 1.0;
  it_.x = memory_.accepted_steps >= 2
              ? Eigen::VectorXd(memory_.accepted_x + ratio * (memory_.accepted_x - memory_.previous_accepted_x))
              : memory_.accepted_x;
  newton_ = 0;
}

void Coordinator::PreSolve(double t, double h) {
  method_->Predict(h);  // (the integrator is at the step's start: BeginTry saved it there)
  method_->Impose(h);
  const bool solved = SolveStep(t, h, nullptr).ok();
  if (!solved) {
    integrator_->Restore(start_);
    iterate_solved_ = false;  // (no solve of this step to start Newton from)
  }
  method_->Linearised(h, solved);
}

// This side failed in iteration `at` (every peer waits for its next message): the integrator back
// at the step's start; the caller rejects the step (adaptive) or ends the run.
Coordinator::Attempt Coordinator::Failed(int at, Attempt::Outcome outcome, Attempt result) {
  integrator_->Restore(start_);
  result.outcome = outcome;
  result.failed_iteration = at;
  result.iterations = at + 1;
  last_iteration_ = at;  // (the StepEnd that rejects it carries this iteration)
  return result;
}

// The step's coupling iterations ended with `last` (converged or not): what the caller needs.
Coordinator::Attempt Coordinator::Finished(int last, Attempt result) {
  last_iteration_ = last;
  result.iterations = last + 1;
  result.impact = !Impacts().empty();
  result.contact = it_.answers.in_contact;
  result.time_to_contact = it_.answers.time_to_contact;
  return result;
}

Coordinator::Attempt Coordinator::Try(double t, double h) {
  Attempt result;
  result.end_time = t + h;
  BeginTry(h);
  if (method_->PreSolves()) PreSolve(t, h);
  // The moving obstacles' frames: the pre-solve's at the step's end; without one (no interface
  // Jacobians, or a pre-solve CGα could not take: iterate_ then holds an earlier step's solve, or
  // nothing in a run's first step) the start's advanced by h.
  if (iterate_solved_) {
    BeginStep(t, h, iterate_, 0.0);
  } else {
    BeginStep(t, h, integrator_->state(), h);
  }
  const bool free_flight = method_->FreeFlight(h);
  CouplingIterationRecord record{step_, 0};
  if (method_->PredictionAgrees(iterate_solved_, &record)) {
    // The pre-solve stands (the integrator holds it): only the imposed rates, which the next
    // step starts from, become the peers' answer.
    rows_.SetSolvedRates(it_.answers.velocity, h);
    log_.push_back(record);
    return Finished(0, result);
  }
  int iteration = 0, backtracks = 0;
  for (;; ++iteration) {
    integrator_->Restore(start_);  // (the state: this try's motion is the solve's input)
    method_->Impose(h);
    result.smooth = SolveStep(t, h, method_->WarmStart(iteration) ? &iterate_ : nullptr);
    record = CouplingIterationRecord{step_, iteration};
    if (!result.smooth.ok()) {
      // With interface Jacobians the smooth step could not take the contact processes' answers;
      // a relaxation's update may be back-tracked (RelaxationMethod::Backtrack).
      result.with_answers = interface_jacobians();
      if (!method_->Backtrack(iteration, ++backtracks, &record)) {
        return Failed(iteration, Attempt::Outcome::kSmoothFailed, result);
      }
      ++backtracks_;
      log_.push_back(record);
      // (The frames of the last iteration that solved; the method keeps that iteration's answers.)
      Exchange(iteration + 1, iterate_);
      continue;
    }
    if (!it_.x_tilde.allFinite()) {
      // (A huge but finite load gives infinite multipliers.) This side's failure, not a message
      // for the peers to refuse.
      return Failed(iteration, Attempt::Outcome::kReactionsNotFinite, result);
    }
    bool skipped = false;
    const bool converged = method_->Converged(iteration, free_flight, &record, &skipped);
    result.outcome = converged ? Attempt::Outcome::kConverged : Attempt::Outcome::kNotConverged;
    if (skipped) {
      result.free_flight = true;
      ++free_flight_;
    }
    if (converged || iteration + 1 >= settings_.max_iterations) {
      record.relaxation_factor = 0.0;
      log_.push_back(record);
      break;
    }
    method_->Next(h, &record);
    log_.push_back(record);
    Exchange(iteration + 1, integrator_->state());
  }
  return Finished(iteration, result);
}

void Coordinator::Accept(double t, double h) {
  CouplingMemory& m = memory_;
  const PeerAnswers& a = it_.answers;
  m.previous_accepted_x = m.accepted_x;
  m.accepted_x = method_->HeldForce();
  // The nodes' motion for the next step's prediction (no acceleration across an impact's jump).
  const std::vector<int> impacts = Impacts();
  m.accepted_acceleration = (a.velocity - m.accepted_velocity) / h;
  for (int k : impacts) m.accepted_acceleration.segment<3>(3 * k).setZero();
  // The peers' law of this step, k = a + S x (a = k̃ − S x̃), and the motion before it.
  m.previous_accepted_position = m.accepted_position;
  m.previous_accepted_velocity = m.accepted_velocity;
  m.previous_accepted_h = m.accepted_h;
  m.offset_known = interface_jacobians() && m.accepted_steps >= 1 && impacts.empty();
  for (size_t k = 0; k < a.sensitivity.size(); ++k) {
    const Eigen::Index o = 3 * static_cast<Eigen::Index>(k);
    m.accepted_offset.segment<3>(o) = a.position.segment<3>(o) - a.sensitivity[k] * a.applied.segment<3>(o);
  }
  m.accepted_position = a.position;
  m.accepted_velocity = a.velocity;
  m.accepted_h = h;
  m.SetSensitivities(a.sensitivity);
  accepted_in_contact_ = a.in_contact;
  accepted_time_to_contact_ = a.time_to_contact;
  ++m.accepted_steps;
  reaction_.Accept(&m);
  if (settings_.restart_at_impact && !impacts.empty()) AfterImpacts(impacts, t, h);
  m.was_contact = a.contact;
  resting_at_start_ = false;
  // Protocol 3: the next StepBegin accepts the step at the peers (or Shutdown's
  // last_accepted_step at the end): no StepEnd round trip.
  last_accepted_ = step_;
  ++step_;
}

void Coordinator::AfterImpacts(const std::vector<int>& impacts, double t, double h) {
  // A new contact (an impact): the points take their nodes' velocities and the history restarts,
  // unless the scenario keeps the smooth model going (restart_at_impact = false: a regularised
  // tie then carries the velocity jump over the next steps; proto/scenario/coupling.proto).
  // The jump is taken by the rigid bodies alone (ProjectImpactVelocities: the beams' and hex27
  // bodies' velocities held), and only where they can take it: a point on a body clamped to a
  // beam (a pad on a beam blade's pitch fitting) is left to its tie, whose compliance passes the
  // jump into the blade over the next steps. Projected in the full mass metric, the jump of a
  // blade's cuff bent the beam's root within the step and the next step's position projection
  // diverged (|Φ| = inf: the first stop impact of generated articulated rotors with beam blades,
  // tests/data/rotors/); moving the whole blade as a rigid body with its cuff ran, but put the
  // Puma gust's blade 1 2.4° RMS off its continuous twin (0.074° when left to the tie): a blade
  // whose bending period is far longer than the impact does not take it as a rigid body. Rigid
  // blades need the restart: without it a regularised tie returns the impact's energy like a
  // spring (the small rotor's anti-flap impact at e = 0.5 rebounds at e ≈ 0.65, 0.5° into its stop).
  // Only the points whose node's contact closed in this step are freed: the rest of the model
  // (another blade resting on its stop) keeps its reactions and accelerations. Not a node of an
  // elastic body or a beam: projected in its consistent mass, the node's velocity jump spreads
  // over its neighbours with alternating signs, and Kelvin–Voigt damping turns that into
  // accelerations of 1e10 m/s² (observed: Newton, or the position projection, failed the step
  // after the first impact of tests/data/impacts/hex27_tip_on_stop.pbtxt and impacts/beam_tip_on_stop.pbtxt);
  // the body takes the jump through its own dynamics, the contact process's impulse having been
  // found with its stiffness E, and keeps the impulse out of its acceleration history
  // (HoldImpactingBodiesHistory).
  std::vector<int> restarted;
  for (int k : impacts) {
    if (!system_.interface_points[static_cast<size_t>(k)].elastic) restarted.push_back(k);
  }
  const DaeState before = integrator_->state();
  DaeState after = before;
  // The points move with their nodes across each impact's plane (along its reaction: Newton's
  // law's velocity); along the plane a node's velocity is its own, which on a stiff tie swings
  // about its point's (Moreau–Jean's midpoint rule does not damp it): imposed whole, it kicked
  // the blade in lag at each impact (generated rotor 648: 11 of 143 restarts failed the
  // projection's 10 % test, the pad's in-plane swing growing to 3 m/s).
  std::vector<Eigen::Vector3d>& normals = impact_normals_;
  normals.assign(system_.interface_points.size(), Eigen::Vector3d::Zero());
  for (int k : restarted) {
    const Eigen::Vector3d f = system_.InterfaceReaction(k, before.lambda);
    if (f.norm() > 0.0) normals[static_cast<size_t>(k)] = f.normalized();
  }
  if (!restarted.empty()) restarted = ProjectImpactVelocities(system_, *data_, t + h, restarted, normals, &after);
  if (!restarted.empty()) {
    // And onto their nodes' reported positions: the tie's stretch c·λ at the impact (0.25 mm
    // for 648's 139 N s) was a spring the next steps released into the node's swing, and the
    // step's point sat at the interface model's imposed value, which then differs from the
    // node's position (648: 0.11 mm along the plane). Not moved, the swing doubled at each
    // re-contact and rotor 639's pad went 0.107 m through its anti-flap plane (exit 3). (If a
    // solve of the move fails, the projection alone stands.)
    for (int k : restarted) {
      for (int j = 0; j < 3; ++j)
        data_->imposed[3 * static_cast<size_t>(k) + static_cast<size_t>(j)].value = it_.answers.position(3 * k + j);
    }
    MoveImpactPointsOntoNodes(system_, *data_, t + h, restarted, normals, &after);
    MoveNodesWithRestart(before, after, restarted);  // (before the restart: it reads them)
    const Eigen::VectorXd a_before = integrator_->acceleration_variable();
    RestartWithCouplingRowsFree(std::move(after), t + h, restarted);
    KeepHistoryTheRestartDidNotChange(before, a_before);
    for (int k : restarted)
      memory_.accepted_x.segment<3>(3 * k).setZero();  // the impact's reaction does not carry over
    memory_.accepted_steps = 0;
    memory_.offset_known = false;
    method_->Forget();  // nor do the secants of the interface map before it
  }
  // (after a restart in the same step, whose consistent accelerations hold the impulse too)
  if (restarted.size() < impacts.size()) HoldImpactingBodiesHistory(impacts, restarted, t + h, h);
}

void Coordinator::MoveNodesWithRestart(const DaeState& before, const DaeState& after,
                                       const std::vector<int>& restarted) {
  // The projection and the move changed the rigid bodies' velocities and positions, and with them
  // every interface point's on them; the nodes, the contact processes', kept theirs. On a stiff
  // tie Moreau–Jean's midpoint rule (θ = ½) does not damp a node's motion relative to its point
  // (the relative velocity changes sign each step, its amplitude kept), so the difference swung
  // for the rest of the run: a teetering yoke's other pad by ±0.13 m/s about its point 300 steps
  // after the first impact, and its own impact then reversed that swinging velocity, not the
  // yoke's (generated rotor 805: left to the tie, 21 ms on the plane, and no stop met after).
  // Each other node takes its point's jump and shift; its motion relative to its point is left as
  // it was: its own answered velocity (with interface Jacobians the imposed rates are the peers'
  // affine model's; sending those changed the relative motion too, and generated rotor 765
  // rebounded from its droop stop to −2.4° where its twin stayed on it). The impacting node keeps
  // its position (the point was moved onto it: moved to its point instead, a node resting on its
  // plane went into it by its tie's stretch at every closing, and a settled blade sank through
  // its stop, GeneratedRotors.ASettledPadSlidesAlongItsStopUntilItsTieHoldsIt) and takes its
  // point's new velocity: Newton's law's across the plane, the point's along it, so that no swing
  // about the point is left (generated rotor 648's bounce series on its anti-flap stop rebounded
  // at 1.19–1.40 times e = 0.704, each impact reversing the swing with the blade's approach).
  moved_points_.clear();
  for (size_t k = 0; k < system_.interface_points.size(); ++k) {
    const InterfacePoint& p = system_.interface_points[k];
    const Eigen::Index o = 3 * static_cast<Eigen::Index>(k);
    const bool impacting = std::find(restarted.begin(), restarted.end(), static_cast<int>(k)) != restarted.end();
    const Eigen::Vector3d jump = impacting
                                     ? Eigen::Vector3d(p.point.Rate(after.qdot) - it_.answers.velocity.segment<3>(o))
                                     : Eigen::Vector3d(p.point.Rate(after.qdot) - p.point.Rate(before.qdot));
    const Eigen::Vector3d shift =
        impacting ? Eigen::Vector3d::Zero() : Eigen::Vector3d(p.point.Value(after.q) - p.point.Value(before.q));
    if (!impacting && jump.norm() < 1e-12 && shift.norm() < 1e-12) continue;  // (a body nothing moved: round-off)
    moved_points_.push_back(static_cast<int>(k));
    it_.answers.velocity.segment<3>(o) += jump;
    it_.answers.position.segment<3>(o) += shift;
    memory_.accepted_velocity.segment<3>(o) = it_.answers.velocity.segment<3>(o);
    memory_.accepted_position.segment<3>(o) = it_.answers.position.segment<3>(o);
    for (int j = 0; j < 3; ++j) {  // (rows as consistent as before)
      data_->imposed[3 * k + static_cast<size_t>(j)].rate += jump(j);
      data_->imposed[3 * k + static_cast<size_t>(j)].value += shift(j);
    }
  }
}

void Coordinator::KeepHistoryTheRestartDidNotChange(const DaeState& before, const Eigen::VectorXd& a_before) {
  // The restart's consistent accelerations are every body's, found with every node's imposed
  // acceleration, (v − v₀)/h, which holds the nodes' swing about their points divided by h. A body
  // whose velocities the restart did not change keeps its own history: reset, another blade
  // lifting off its droop stop took −0.03 rad/s in the next step with no contact of its own and
  // chattered on the stop every 9 ms (generated rotor 651, blade 1). Per rigid body (a beam's
  // node included), per coordinate of a hex27 body. Unchanged: by at most 1e-3 of the largest
  // change of any coordinate. The solves' round-off on a body the impulse does not reach (another
  // blade on a driven hub) is up to 1e-8 of it, the impacting blade's bodies change by 0.4–1
  // (generated rotor 648); a bound within the round-off's range (1e-12 absolute, 1e-9 relative)
  // fell on either side of it in a run and in its restart from a saved state, which departed
  // from the run made in one go by up to 0.29° (rotors 600, 648, 651, 780).
  const DaeState& now = integrator_->state();
  const double dv = (now.qdot - before.qdot).lpNorm<Eigen::Infinity>(),
               dq = (now.q - before.q).lpNorm<Eigen::Infinity>();
  held_a_ = integrator_->acceleration_variable();
  held_qddot_ = now.qddot;
  const Eigen::Index n = system_.coordinates;
  const Eigen::Index rigid = system_.rigid_coordinates();
  bool kept = false;
  for (Eigen::Index o = 0; o < n;) {
    const Eigen::Index count = o < rigid ? kCoordinatesPerBody : 1;
    if ((now.qdot.segment(o, count) - before.qdot.segment(o, count)).lpNorm<Eigen::Infinity>() <= 1e-3 * dv &&
        (now.q.segment(o, count) - before.q.segment(o, count)).lpNorm<Eigen::Infinity>() <= 1e-3 * dq) {
      held_a_.segment(o, count) = a_before.segment(o, count);
      held_qddot_.segment(o, count) = before.qddot.segment(o, count);
      kept = true;
    }
    o += count;
  }
  if (kept) integrator_->ReplaceAccelerationHistory(held_a_, held_qddot_);
}

void Coordinator::HoldImpactingBodiesHistory(const std::vector<int>& impacts, const std::vector<int>& restarted,
                                             double t, double h) {
  // An impact left to its tie (an elastic node's; restart_at_impact restarts the rigid bodies'):
  // the impulse reached the smooth model within the step through the tie's multiplier, and the
  // step's a_{n+1} and q̈_{n+1} hold it divided by h on the bodies it moved. Carried on by
  // Eq. (3) and by Newmark's (1 − γ) h a_n and h² (½ − β) a_n, it pushed the blade on after its
  // rebound at every impact: a light pad on a beam node rattling between its stops gained energy
  // until the step failed (generated hingeless rotors 353, 383 and 458: exit 3) or the pad went
  // through its stop (551); a pad on an articulated blade's cuff (a rigid body the restart cannot
  // move: the beam clamped beyond it) likewise (801: the position projection diverged at 1.18 s).
  // The nonsmooth generalised-α keeps impulses out of the recurrence (Chen, Acary, Virlez &
  // Brüls, IJNME 96:487–511, 2013); here those bodies' history is the step before's, its last
  // impulse-free one, turned with each body over the step, and their positions, velocities and
  // multipliers the step's own. Only those bodies': held for every body, the other blades'
  // centripetal accelerations, turned by Ωh since, kicked them at each impact (generated rotor
  // 707, 116 rad/s: exit 3 at 0.86 s); the step's linearising pre-solve as the impulse-free
  // history let pads through their stops (seeds 2, 5 and 722). docs/design.md, "Impacts and the
  // restart".
  std::vector<bool> held(static_cast<size_t>(system_.coordinates), false);
  std::vector<int> turned;
  for (int k : impacts) {
    if (std::find(restarted.begin(), restarted.end(), k) != restarted.end()) continue;
    for (int b : BodiesTheImpulseMovedInTheStep(k, t, h)) {
      turned.push_back(b);
      for (int j = 0; j < kCoordinatesPerBody; ++j) held[static_cast<size_t>(kCoordinatesPerBody * b + j)] = true;
    }
    const InterfacePoint& p = system_.interface_points[static_cast<size_t>(k)];
    for (size_t e = 0; e < system_.elastic.size(); ++e) {  // a hex27 body's node: the body's
      const int first = system_.elastic_offset[e], count = 3 * system_.elastic[e]->body.node_count();
      const bool on = std::any_of(p.point.terms.begin(), p.point.terms.end(), [&](const LinearVector::Term& term) {
        return term.offset >= first && term.offset < first + count;
      });
      for (int j = 0; on && j < count; ++j) held[static_cast<size_t>(first + j)] = true;
    }
  }
  if (std::find(held.begin(), held.end(), true) == held.end()) return;
  held_a_ = integrator_->acceleration_variable();  // (equal sizes: no allocation once warm)
  held_qddot_ = integrator_->state().qddot;
  for (size_t i = 0; i < held.size(); ++i) {
    if (!held[i]) continue;
    held_a_(static_cast<Eigen::Index>(i)) = start_.a(static_cast<Eigen::Index>(i));
    held_qddot_(static_cast<Eigen::Index>(i)) = start_.state.qddot(static_cast<Eigen::Index>(i));
  }
  for (int b : turned) {
    // Each [x, u, v, w] block of the step before's accelerations turned by the body's rotation
    // over the step, E_{n+1} E_n⁻¹: a blade spinning at Ω has turned by Ωh, and its centripetal
    // accelerations with it (held unturned, they kick the blade by Ω²·Ωh at every impact).
    const Eigen::Index o = static_cast<Eigen::Index>(kCoordinatesPerBody) * b;
    Eigen::Matrix3d e0, e1;
    for (int c = 0; c < 3; ++c) {
      e0.col(c) = start_.state.q.segment<3>(o + 3 + 3 * c);
      e1.col(c) = integrator_->state().q.segment<3>(o + 3 + 3 * c);
    }
    const Eigen::Matrix3d turn = e1 * e0.inverse();
    for (int c = 0; c < 4; ++c) {
      held_a_.segment<3>(o + 3 * c) = turn * start_.a.segment<3>(o + 3 * c);
      held_qddot_.segment<3>(o + 3 * c) = turn * start_.state.qddot.segment<3>(o + 3 * c);
    }
  }
  integrator_->ReplaceAccelerationHistory(held_a_, held_qddot_);
  ++impacts_held_;
}

std::vector<int> Coordinator::BodiesTheImpulseMovedInTheStep(int k, double t, double h) const {
  // The bodies an impulse at point k moves at once through the constraints (for a beam's node,
  // its body), each beam among them with all its nodes; none if the tie did not deliver the
  // impulse within the step: its half period π √(m c) on the effective mass m the point's
  // reaction meets is longer than h. Such a tie is a spring the impact compresses over several
  // steps, and its force a real one of each: held, a two-blade teetering rotor's yoke (m = 240 kg
  // at the pad, c = 9.2e-9 m/N: 4.7 ms) pressed onto its stop by a gust bounced on it for 0.8 s
  // where its twin rested after one bounce (generated rotor 679; 646: exit 3). An articulated
  // cuff's pad (801: 1.3 kg, 1.1e-9 m/N, 0.12 ms) and a hingeless beam node's are held.
  const InterfacePoint& p = system_.interface_points[static_cast<size_t>(k)];
  if (p.body < 0) return {};  // (a hex27 node: HoldImpactingBodiesHistory holds its body)
  const auto beam_of = [&](int b) -> const std::vector<int>* {
    for (const std::vector<int>& nodes : system_.beam_node_bodies) {
      if (std::find(nodes.begin(), nodes.end(), b) != nodes.end()) return &nodes;
    }
    return nullptr;
  };
  Eigen::Matrix3d mobility = Eigen::Matrix3d::Zero();  // point velocity per unit impulse
  std::vector<int> moved = BodiesAnImpulseMoves(system_, *data_, t, integrator_->state().q, k, &mobility);
  if (beam_of(p.body) != nullptr) moved = {p.body};
  const Eigen::Vector3d force = system_.InterfaceReaction(k, integrator_->state().lambda);
  if (force.norm() == 0.0) return {};
  const Eigen::Vector3d n = force.normalized();
  const double mass = 1.0 / n.dot(mobility * n);
  if (!(M_PI * std::sqrt(mass * p.regularization) < h)) return {};
  std::vector<int> out;
  for (int b : moved) {
    const std::vector<int>* beam = beam_of(b);
    for (int c : beam != nullptr ? *beam : std::vector<int>{b}) {
      if (std::find(out.begin(), out.end(), c) == out.end()) out.push_back(c);
    }
  }
  return out;
}

std::vector<int> Coordinator::Impacts() const {
  // A settled start's first step closes no contact: its nodes rest on their stops (the settle's
  // equilibrium, no approach speed), and their contacts, reported closed in that step, are not
  // impacts. Restarted there, a rod settled on its stop lost 79 % of its pad's steady impulse and
  // a settled rotor's blade rose 0.023° off its droop stop (the tie's static stretch moved away).
  if (resting_at_start_) return {};
  std::vector<int> points;
  for (size_t k = 0; k < it_.answers.contact.size(); ++k) {
    if (it_.answers.contact[k] && !memory_.was_contact[k]) points.push_back(static_cast<int>(k));
  }
  return points;
}

void Coordinator::Reject() {
  integrator_->Restore(start_);
  // A rejected step leaves no trace: its answers (the sensitivities of a step of another length,
  // h²θ/m for a free node; its contact flags) are not the accepted state's, and the next try
  // starts from the accepted ones, as a run taking that step from the start would.
  memory_.GetSensitivities(&it_.answers.sensitivity);
  it_.answers.in_contact = accepted_in_contact_;
  it_.answers.time_to_contact = accepted_time_to_contact_;
  method_->Forget();  // secants of a step of another length
  link_.EndStep(step_, last_iteration_, /*accepted=*/false, /*converged=*/false);
  ++rejected_;
}

void Coordinator::Shutdown(int exit_code, const std::string& reason, bool wait_for_replies) {
  link_.Shutdown(exit_code, reason, last_accepted_, Moved(), wait_for_replies);
}

}  // namespace cosim::smooth
