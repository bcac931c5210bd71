#include "smooth_solver/simulation/multibody_simulation.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <numbers>
#include <optional>
#include <set>

#include "interface/base/input_file.h"
#include "interface/scenario/checks.h"
#include "smooth_solver/analysis/rotating_frame.h"
#include "smooth_solver/integrator/cgalpha_index2.h"
#include "smooth_solver/integrator/integrator_settings.h"
#include "smooth_solver/simulation/node_rest.h"
#include "smooth_solver/simulation/saved_state.h"
#include "smooth_solver/simulation/visual_scene.h"
#include "state.pb.h"

namespace cosim::smooth {

using interface::Checks;
using interface::ElementPath;
namespace sc = cosim::scenario;

namespace {

// numerics.initial_state: the saved state, checked against this scene and start time.
state::SmoothState ReadRestart(const Checks& checks, const interface::ScenarioFile& file, const std::string& scenario,
                               const MultibodySystem& system, size_t joints, double start_time) {
  const std::string place = "numerics.initial_state";
  const std::filesystem::path path = file.PathBeside(file.proto().numerics().initial_state());
  const interface::InputFile bytes = interface::ReadInputFile(path, interface::kMaxStateBytes);
  if (!bytes.ok()) checks.Fail(place, bytes.why + "; expected a final_state.pb (a smooth run's saved state)");
  state::SmoothState s;
  if (!s.ParseFromString(bytes.text)) {
    checks.Fail(place, "'" + path.string() + "' is not a readable final_state.pb (a smooth run's saved state)");
  }
  if (s.scenario() != scenario) {
    checks.Fail(place, "'" + path.string() + "' is a state of scenario '" + interface::EchoedText(s.scenario()) +
                           "', not of '" + scenario + "'; expected a state written by a run of this scene");
  }
  if (s.coordinates() != system.coordinates || s.constraints() != system.constraints.size() ||
      s.q_size() != system.coordinates || s.qdot_size() != system.coordinates ||
      s.reference_q_size() != system.coordinates || s.angle_offsets_size() != static_cast<int>(joints)) {
    checks.Fail(place, "'" + path.string() + "' holds a state of " + std::to_string(s.coordinates()) +
                           " coordinates and " + std::to_string(s.constraints()) + " constraints (scenario '" +
                           interface::EchoedText(s.scenario()) + "'); this scene has " +
                           std::to_string(system.coordinates) + " and " + std::to_string(system.constraints.size()) +
                           ": expected a state written by a run of the same scene");
  }
  checks.StateTime("the state", s.time(), start_time);
  if (!std::isfinite(s.reference_time())) {  // (carried into the states this run saves)
    checks.Fail(place, "'" + path.string() + "' has a reference_time of " +
                           interface::FormatNumber(s.reference_time()) +
                           "; expected a finite time (a state written by a run of this scene)");
  }
  for (int i = 0; i < s.q_size(); ++i) {
    if (!std::isfinite(s.q(i)) || !std::isfinite(s.qdot(i))) {
      checks.Fail(place,
                  "'" + path.string() + "' has a non-finite coordinate or velocity at index " + std::to_string(i));
    }
  }
  return s;
}

// A global vector in the axes of body `frame` (−1: global, unchanged).
Eigen::Vector3d InFrame(int frame, const Eigen::VectorXd& q, const Eigen::Vector3d& v) {
  if (frame < 0) return v;
  return BodyAxes(q, frame).transpose() * v;
}

// For a static solve that did not converge: the advice to raise the iteration limit, only where
// the residual came down. More iterations help only iterates that were closing in: a generated
// articulated rotor's twin (tests/data/rotors/articulated_beam_settled_gust) with its droop stops
// at −0.6 rad went from 245 N at the guess to 357 kN after 50 iterations and 222 kN after 200;
// with them at −0.15 rad, to 0.057 N after 50, and it settles with 200.
std::string MoreIterationsAdvice(const EquilibriumResult& r) {
  return r.residual < r.initial_residual ? ", or raise numerics.smooth.newton_max_iterations" : "";
}

}  // namespace

MultibodySimulation::MultibodySimulation(const interface::ScenarioFile& file, bool coupled)
    : model_(BuildMultibodyModel(file)) {
  const Checks checks(file);
  visual_.axis_length = file.proto().output().visual().axis_length();
  if (!(visual_.axis_length >= 0.0)) {
    checks.Fail("output.visual.axis_length",
                "must be >= 0 (0: a quarter of each body's size), got " + interface::FormatNumber(visual_.axis_length));
  }
  if (!coupled && !model_.interface_points.empty()) {
    // Standalone, nothing would move the imposed points: they would stay where they start.
    checks.Fail("coupling.interface_nodes",
                "a coupled scene needs its contact processes; smooth_solver alone cannot "
                "run it; scripts/cosim run starts them and sets their endpoints");
  }
  std::vector<ElasticBodySpec> elastic = ElasticBodies(checks, file);
  const StepSettings settings = ReadStepSettings(checks, file, coupled);
  probes_ = ReadSmoothProbes(checks, file, coupled, model_, elastic);
  BuildSystemAndState(checks, file, coupled, settings, &elastic);
}

std::vector<ElasticBodySpec> MultibodySimulation::ElasticBodies(const Checks& checks,
                                                                const interface::ScenarioFile& file) {
  std::vector<ElasticBodySpec> elastic = BuildElasticBodies(checks, file.proto().model(), model_.BodyNames());
  std::map<std::string, int> elastic_index;
  for (size_t e = 0; e < elastic.size(); ++e) elastic_index[elastic[e].name] = static_cast<int>(e);
  // Interface nodes on elastic bodies: which node.
  for (size_t k = 0; k < model_.interface_points.size(); ++k) {
    InterfacePointSpec& spec = model_.interface_points[k];
    if (spec.elastic_body.empty()) continue;
    spec.elastic = elastic_index.at(spec.elastic_body);
    spec.elastic_node = elastic[static_cast<size_t>(spec.elastic)].FindPoint(
        checks, interface::ElementPath("coupling.interface_nodes", static_cast<int>(k)) + ".node", spec.elastic_point);
  }
  if (model_.bodies.empty() && elastic.empty()) {
    checks.Fail("model.bodies", "the smooth solver needs at least one rigid or elastic body");
  }
  return elastic;
}

MultibodySimulation::StepSettings MultibodySimulation::ReadStepSettings(const Checks& checks,
                                                                        const interface::ScenarioFile& file,
                                                                        bool coupled) {
  StepSettings out;
  scenario_name_ = interface::ScenarioName(file);
  numerics_.CopyFrom(file.proto().numerics());
  interface::MaterializeDefaults(&numerics_);
  numerics_.clear_nonsmooth();
  const sc::SmoothSettings& s = numerics_.smooth();
  ida_ = ReadIntegrator(checks, s) == sc::SmoothSettings::IDA;
  out.ida = ReadIdaSettings(checks, s);
  out.cgalpha = ReadCgAlphaSettings(checks, s, model_.bodies);
  if (s.analysis() == sc::SmoothSettings::STATIC) {
    // A STATIC analysis of a scene with beams or rigid bodies: the equilibrium at each output
    // time (StaticStep). Hex27 bodies alone take ElasticStaticSimulation.
    if (coupled)
      checks.Fail("numerics.smooth.analysis", "a coupled run is DYNAMIC; STATIC is of the smooth model alone");
    if (file.proto().model().elastic_bodies_size() > 0) {
      checks.Fail("numerics.smooth.analysis",
                  "STATIC takes hex27 elastic bodies alone, or beams and rigid bodies "
                  "without them; this scene has both (use DYNAMIC)");
    }
    if (numerics_.adaptive().enabled()) {
      checks.Fail("numerics.adaptive.enabled", "a STATIC analysis takes no time steps to adapt; set enabled: false");
    }
    static_ = true;
  }
  if (numerics_.adaptive().enabled()) adaptive_ = AdaptiveController(ReadAdaptiveSettings(checks, numerics_, coupled));
  out.watchdog = ReadWatchdogSettings(checks, s.watchdog(), &out.energy_check);
  return out;
}

void MultibodySimulation::BuildSystemAndState(const Checks& checks, const interface::ScenarioFile& file, bool coupled,
                                              const StepSettings& settings, std::vector<ElasticBodySpec>* elastic) {
  auto system = std::make_unique<MultibodySystem>(BuildMultibodySystem(model_, elastic));
  data_ = std::make_unique<SystemData>(MakeData(*system));
  time_ = numerics_.start_time();
  // A restart (numerics.initial_state) does not close the loops again: the first run's
  // consistent initial configuration, saved with the state, is the probes' reference and fixes
  // the closed locks, as it did in that run.
  std::optional<state::SmoothState> restart;
  if (numerics_.has_initial_state()) {
    restart = ReadRestart(checks, file, scenario_name_, *system, model_.joints.size(), time_);
  }
  DaeState initial;
  if (restart) {
    initial.q = Eigen::Map<const Eigen::VectorXd>(restart->reference_q().data(), restart->reference_q_size());
    initial.qdot = Eigen::VectorXd::Zero(initial.q.size());
  } else {
    // Elements with a memory (contact laws' onset speed, rotor inflow) start from the user's
    // guess, so the consistent state's accelerations see an inflow, then from that state.
    system->AcceptStep(system->q0, system->qdot0, time_, data_.get());
    initial = ConsistentInitialState(*system, *data_, time_, &initial_report_);
  }
  HoldClosedLocks(system.get(), *data_, initial.q, time_);
  reference_q_ = initial.q;
  if (numerics_.smooth().settle()) Settle(checks, coupled, system.get(), &initial);
  reference_time_ = restart ? restart->reference_time() : time_;
  system_ = std::move(system);
  if (!restart) system_->AcceptStep(initial.q, initial.qdot, time_, data_.get());
  SetProbeReferences(initial.q);
  if (restart) {
    initial.q = Eigen::Map<const Eigen::VectorXd>(restart->q().data(), restart->q_size());
    initial.qdot = Eigen::Map<const Eigen::VectorXd>(restart->qdot().data(), restart->qdot_size());
    if (HasSavedData(*restart)) {  // the memories and inflow as the first run left them
      const std::string mismatch = ReadData(*restart, data_.get());
      if (!mismatch.empty()) checks.Fail("numerics.initial_state", mismatch + ": expected a state of this scene");
    } else {  // (a state saved before the data was): from the saved state
      system_->AcceptStep(initial.q, initial.qdot, time_, data_.get());
    }
    ConsistentAccelerations(*system_, *data_, time_, &initial);
  }
  if (ida_) {
    integrator_ = std::make_unique<IdaReference>(*system_, *data_, settings.ida, initial, time_);
  } else if (numerics_.smooth().integrator() == sc::SmoothSettings::CGALPHA_INDEX2) {
    integrator_ = std::make_unique<CgAlphaIndex2>(*system_, *data_, settings.cgalpha, initial);
  } else {
    // Its checkpoints (rejected steps, coupling iterations) save and restore the data too.
    auto cg = std::make_unique<CgAlpha>(*system_, data_.get(), settings.cgalpha, initial);
    // A restart of a CGα run continues its history (a_n, f̃_n, the step's accelerations and
    // multipliers): the run goes on as if it had not stopped; a coupled run's coordinator then
    // restores its own memory saved with it (saved_coordinator).
    CgAlpha::Checkpoint history;
    if (restart && HistoryFits(*restart, HistoryOf{numerics_.step(), settings.cgalpha, adaptive()})) {
      const std::string wrong = ReadCgAlphaHistory(*restart, initial, system_->constraints.size(), &history);
      if (!wrong.empty()) checks.Fail("numerics.initial_state", wrong + ": expected a state of this scene");
      history.data = *data_;
      cg->Restore(history);
      if (restart->has_next_step() && restart->next_step() > 0.0) {
        // (a run may have ended below min_step)
        adaptive_.set_next_step(std::max(restart->next_step(), adaptive_.settings().min_step));
      }
      if (restart->has_coordinator()) saved_coordinator_ = restart->coordinator();
    }
    cg_ = cg.get();
    if (adaptive()) stepper_ = std::make_unique<CgAlphaStepper>(cg_);
    integrator_ = std::move(cg);
  }
  if (adaptive() && !integrator_->capabilities().error_estimate) {
    checks.Fail("numerics.adaptive",
                "only numerics.smooth.integrator CGALPHA takes adaptive steps (IDA chooses its "
                "own); set enabled: false");
  }
  WatchdogSettings watchdog = settings.watchdog;
  watchdog.energy = settings.energy_check == sc::Watchdog::ON ||
                    (settings.energy_check == sc::Watchdog::AUTO && PassiveSystem(*system_));
  watchdog_ = std::make_unique<Watchdog>(*system_, watchdog, model_.BodyNames(), initial);
  // Angles continue past ±π (whole turns counted), from each joint's initial coordinate.
  angle_offset_.assign(model_.joints.size(), 0.0);
  for (size_t j = 0; j < model_.joints.size(); ++j) {
    angle_offset_[j] = restart ? restart->angle_offsets(static_cast<int>(j)) : model_.joints[j].initial_coordinate;
  }
  last_angle_.assign(model_.joints.size(), 0.0);
  for (size_t j = 0; j < model_.joints.size(); ++j) {
    if (system_->joints[j].rotational) last_angle_[j] = system_->JointCoordinate(static_cast<int>(j), initial.q);
  }
  max_violation_ = integrator_->ConstraintViolation(time_);
  probe_time_ = time_;
}

// The initial positions and orientations that displacement and rotation probes measure from.
void MultibodySimulation::SetProbeReferences(const Eigen::VectorXd& q) {
  for (ProbeSpec& p : probes_) {
    if (p.kind != Kind::kBodyDisplacement && p.kind != Kind::kRotation && p.kind != Kind::kDisplacement) continue;
    // The point: a body's origin, or an elastic body's node.
    const int o = p.kind == Kind::kDisplacement ? system_->elastic_offset[static_cast<size_t>(p.index)] + 3 * p.node
                                                : kCoordinatesPerBody * p.index;
    Eigen::Matrix3d B = Eigen::Matrix3d::Identity(), F = Eigen::Matrix3d::Identity();
    Eigen::Vector3d xF = Eigen::Vector3d::Zero();
    if (p.kind != Kind::kDisplacement) {
      B = BodyAxes(q, p.index);
    }
    if (p.frame >= 0) {
      const int f = kCoordinatesPerBody * p.frame;
      xF = q.segment<3>(f);
      F = BodyAxes(q, p.frame);
    }
    p.initial_position = F.transpose() * (Eigen::Vector3d(q.segment<3>(o)) - xF);
    if (p.kind != Kind::kDisplacement) p.initial_orientation = F.transpose() * B;
  }
}

std::vector<std::string> MultibodySimulation::ProbeNames() const {
  std::vector<std::string> names;
  for (const auto& p : probes_) names.push_back(p.name);
  return names;
}

Eigen::Vector3d MultibodySimulation::BodyVector(const ProbeSpec& p) const {
  const DaeState& s = interpolated_ ? shown_ : integrator_->state();
  const int o = kCoordinatesPerBody * p.index;
  Eigen::Matrix3d F = Eigen::Matrix3d::Identity();
  Eigen::Vector3d xF = Eigen::Vector3d::Zero(), vF = xF, aF = xF, wF = xF, alphaF = xF;
  if (p.frame >= 0) {
    const int f = kCoordinatesPerBody * p.frame;
    F = BodyAxes(s.q, p.frame);
    xF = s.q.segment<3>(f);
    vF = s.qdot.segment<3>(f);
    aF = s.qddot.segment<3>(f);
    wF = BodyAngularRate(s.q, s.qdot, p.frame);
    alphaF = BodyAngularRate(s.q, s.qddot, p.frame);
  }
  const Eigen::Vector3d r = s.q.segment<3>(o) - xF;
  // Velocity and acceleration as seen from the moving frame (relative kinematics).
  const Eigen::Vector3d v_rel = s.qdot.segment<3>(o) - vF - wF.cross(r);
  switch (p.kind) {
    case Kind::kPosition:
      return F.transpose() * r;
    case Kind::kVelocity:
      return F.transpose() * v_rel;
    case Kind::kAcceleration:
      return F.transpose() * (Eigen::Vector3d(s.qddot.segment<3>(o)) - aF - alphaF.cross(r) - wF.cross(wF.cross(r)) -
                              2.0 * wF.cross(v_rel));
    case Kind::kAngularVelocity:
      return F.transpose() * (BodyAngularRate(s.q, s.qdot, p.index) - wF);
    case Kind::kBodyDisplacement:
      return F.transpose() * r - p.initial_position;
    case Kind::kRotation: {
      const Eigen::Matrix3d B = BodyAxes(s.q, p.index);
      // Rotation from the initial relative orientation to the present one, in the frame's axes.
      const Eigen::AngleAxisd aa(
          Eigen::Quaterniond(F.transpose() * B * p.initial_orientation.transpose()).normalized());
      return aa.angle() * aa.axis();
    }
    default:
      return Eigen::Vector3d::Zero();
  }
}

void MultibodySimulation::Visual(interface::VisualFrame* frame) const {
  DrawScene(model_, *system_, *data_, (interpolated_ ? shown_ : integrator_->state()).q, visual_, frame);
}

// An aero section's or a rotor's probe at the state `s`.
double MultibodySimulation::AeroProbe(const ProbeSpec& p, const DaeState& s) const {
  if (p.kind == Kind::kAeroAlpha || p.kind == Kind::kAeroForce || p.kind == Kind::kAeroMoment ||
      p.kind == Kind::kAeroMach) {
    const AirLoads& air = *system_->air_loads;
    const AirLoads::SectionResult r =
        air.Evaluate(air.Section(p.index, p.station, 1.0), s.q, s.qdot, probe_time_, *data_);
    return p.kind == Kind::kAeroAlpha    ? r.alpha
           : p.kind == Kind::kAeroMoment ? r.moment
           : p.kind == Kind::kAeroMach   ? r.mach
                                         : interface::PickComponent(r.force_local, p.component);
  }
  const AirLoads::RotorResult r = system_->air_loads->Rotor(p.index, s.q, s.qdot, probe_time_, *data_);
  return p.kind == Kind::kRotorThrust   ? r.thrust
         : p.kind == Kind::kRotorTorque ? r.torque
         : p.kind == Kind::kInflowRatio ? r.inflow_ratio
                                        : r.induced;
}

// A joint's coordinate, revolute angles unwrapped across ±π, from the joint's initial coordinate.
double MultibodySimulation::JointCoordinateProbe(const ProbeSpec& p, const Eigen::VectorXd& q) const {
  double value = system_->JointCoordinate(p.index, q);
  if (system_->joints[static_cast<size_t>(p.index)].rotational) {
    // An interpolated state lies within the last step: on last_angle_'s side of ±π.
    const double last = last_angle_[static_cast<size_t>(p.index)];
    if (value - last > std::numbers::pi) value -= 2.0 * std::numbers::pi;
    if (value - last < -std::numbers::pi) value += 2.0 * std::numbers::pi;
    value += angle_offset_[static_cast<size_t>(p.index)];
  } else {
    value += model_.joints[static_cast<size_t>(p.index)].initial_coordinate;
  }
  return value;
}

// An elastic body's node displacement, in the probe's frame (from the initial relative position).
double MultibodySimulation::NodeDisplacementProbe(const ProbeSpec& p, const Eigen::VectorXd& q) const {
  const int at = system_->elastic_offset[static_cast<size_t>(p.index)] + 3 * p.node;
  Eigen::Vector3d d;
  if (p.frame >= 0) {  // relative to the frame, in its axes, from the initial relative position
    const int f = kCoordinatesPerBody * p.frame;
    const Eigen::Matrix3d F = BodyAxes(q, p.frame);
    d = F.transpose() * (Eigen::Vector3d(q.segment<3>(at)) - Eigen::Vector3d(q.segment<3>(f))) - p.initial_position;
  } else {
    d = Eigen::Vector3d(q.segment<3>(at)) -
        system_->elastic[static_cast<size_t>(p.index)]->body.mesh().nodes.col(p.node);
  }
  return interface::PickComponent(d, p.component);
}

void MultibodySimulation::Probe(std::vector<double>* values) const {
  const DaeState& s = interpolated_ ? shown_ : integrator_->state();
  for (size_t i = 0; i < probes_.size(); ++i) {
    const ProbeSpec& p = probes_[i];
    double value = 0.0;
    switch (p.kind) {
      case Kind::kPosition:
      case Kind::kVelocity:
      case Kind::kAcceleration:
      case Kind::kAngularVelocity:
      case Kind::kBodyDisplacement:
      case Kind::kRotation:
        value = interface::PickComponent(BodyVector(p), p.component);
        break;
      case Kind::kBeamStrainEnergy:
        value = system_->beam_forces[static_cast<size_t>(p.index)]->PotentialEnergy(s.q);
        break;
      case Kind::kSectionForce:
      case Kind::kSectionMoment: {
        const Vector6d sigma = system_->beam_forces[static_cast<size_t>(p.index)]->SectionForces(s.q, p.station);
        value = interface::PickComponent(
            p.kind == Kind::kSectionForce ? Eigen::Vector3d(sigma.head<3>()) : Eigen::Vector3d(sigma.tail<3>()),
            p.component);
        break;
      }
      case Kind::kAeroAlpha:
      case Kind::kAeroForce:
      case Kind::kAeroMoment:
      case Kind::kAeroMach:
      case Kind::kRotorThrust:
      case Kind::kRotorTorque:
      case Kind::kInflowRatio:
      case Kind::kInducedVelocity:
        value = AeroProbe(p, s);
        break;
      case Kind::kContactForce:
        for (const UnilateralContact* law : system_->contact_laws[static_cast<size_t>(p.index)])
          value += law->LawForce(s.q, s.qdot, *data_);
        break;
      case Kind::kJointCoordinate:
        value = JointCoordinateProbe(p, s.q);
        break;
      case Kind::kJointSpeed:
        value = system_->JointRate(p.index, s.q, s.qdot);
        break;
      case Kind::kReactionForce:
        value = interface::PickComponent(
            InFrame(p.frame, s.q, system_->JointReactionForce(p.index, s.q, s.lambda, probe_time_, *data_)),
            p.component);
        break;
      case Kind::kReactionMoment:
        value = interface::PickComponent(
            InFrame(p.frame, s.q, system_->JointReactionMoment(p.index, s.q, s.lambda, probe_time_, *data_)),
            p.component);
        break;
      case Kind::kKinetic:
        value = system_->KineticEnergy(s.qdot);
        break;
      case Kind::kPotential:
        value = system_->PotentialEnergy(s.q);
        break;
      case Kind::kTotal:
        value = system_->KineticEnergy(s.qdot) + system_->PotentialEnergy(s.q);
        break;
      case Kind::kViolation:
        value = Violation(s.q);
        break;
      case Kind::kDisplacement:
        value = NodeDisplacementProbe(p, s.q);
        break;
      case Kind::kClampForce:
      case Kind::kClampMoment: {
        Eigen::Vector3d force, moment;
        system_->ClampReaction(p.index, s.q, s.lambda, &force, &moment);
        value =
            interface::PickComponent(InFrame(p.frame, s.q, p.kind == Kind::kClampForce ? force : moment), p.component);
        break;
      }
      case Kind::kStrainEnergy: {
        const auto& body = system_->elastic[static_cast<size_t>(p.index)]->body;
        value = body.StrainEnergy(Eigen::Map<const Eigen::Matrix3Xd>(
            s.q.data() + system_->elastic_offset[static_cast<size_t>(p.index)], 3, body.node_count()));
        break;
      }
    }
    (*values)[i] = value;
  }
}

double MultibodySimulation::Violation(const Eigen::VectorXd& q) const {
  if (!interpolated_) return integrator_->ConstraintViolation(time_);
  Eigen::VectorXd phi(system_->constraints.size());
  system_->constraints.Evaluate(data_->imposed, q, probe_time_, phi);
  return phi.size() > 0 ? phi.lpNorm<Eigen::Infinity>() : 0.0;
}

void MultibodySimulation::Step(double t, double h) {
  if (static_) {
    StaticStep(t + h);
    return;
  }
  if (!adaptive()) {
    Record(t + h, cg_ != nullptr ? StepOrSplit(*cg_, t, h, 0) : integrator_->Step(t, h));
    return;
  }
  Advance(t + h, *stepper_);
}

// A fixed CGα step that fails is redone as two halves, a half that fails as two quarters, before
// the run ends (as a coupled step is: Coordinator::StepOrSplit). Generated rotors' continuous
// twins failed a step at h (a 2.35 m blade at 75 rad/s, Newton in its second step) that h/2
// takes; the history keeps its grid (the substeps end where the step ends).
int MultibodySimulation::StepOrSplit(CgAlpha& cg, double t, double h, int depth) {
  const StepStatus status = cg.TryStep(t, h);  // (a failed try leaves the integrator as it was)
  if (status.ok()) return status.iterations;
  if (depth >= StepStatus::kRetrySplits) {
    std::string why = status.Describe(cg.settings());
    if (depth > 0) why = StepStatus::AfterRetries(why, 1 << depth, h, t);
    throw NumericalError(why);
  }
  ++retried_steps_;
  const int first = StepOrSplit(cg, t, 0.5 * h, depth + 1);
  return first + StepOrSplit(cg, t + 0.5 * h, 0.5 * h, depth + 1);
}

void MultibodySimulation::Advance(double target, Stepper& stepper) {
  const double eps = 1e-12 * std::max(1.0, std::abs(target));
  adaptive_.StartWith(numerics_.step());
  adaptive_.Advance(time_, target, numerics_.end_time(), stepper, *system_, [&](double t, double h, int iterations) {
    previous_ = stepper.start().state;
    previous_time_ = t;
    Record(t + h, iterations);
  });
  probe_time_ = target;
  interpolated_ = false;  // a step that ended on the target, now or in an earlier call
  if (std::abs(time_ - target) > eps) Interpolate(target);
}

void MultibodySimulation::Interpolate(double t) {
  // Cubic Hermite between the last two accepted states: q from (q, q̇), q̇ from (q̇, q̈) at both
  // ends; q̈ and λ linear. O(H⁴) in q: below the step's own error.
  const DaeState& b = integrator_->state();
  const DaeState& a = previous_;
  const double H = time_ - previous_time_, s = (t - previous_time_) / H;
  const double h00 = (1.0 + 2.0 * s) * (1.0 - s) * (1.0 - s), h10 = s * (1.0 - s) * (1.0 - s);
  const double h01 = s * s * (3.0 - 2.0 * s), h11 = s * s * (s - 1.0);
  shown_.q = h00 * a.q + (h10 * H) * a.qdot + h01 * b.q + (h11 * H) * b.qdot;
  shown_.qdot = h00 * a.qdot + (h10 * H) * a.qddot + h01 * b.qdot + (h11 * H) * b.qddot;
  shown_.qddot = (1.0 - s) * a.qddot + s * b.qddot;
  shown_.lambda = (1.0 - s) * a.lambda + s * b.lambda;
  interpolated_ = true;
}

CgAlpha* MultibodySimulation::cgalpha() { return cg_; }

void MultibodySimulation::Settle(const Checks& checks, bool coupled, MultibodySystem* system, DaeState* initial) {
  const std::string place = "numerics.smooth.settle";
  if (numerics_.has_initial_state())
    checks.Fail(place,
                "a run from a saved state (numerics.initial_state) is settled "
                "already; remove one of them");
  if (static_ || numerics_.smooth().analysis() != sc::SmoothSettings::DYNAMIC) {
    checks.Fail(place, "settles the start of a DYNAMIC analysis; remove it");
  }
  if (numerics_.smooth().integrator() == sc::SmoothSettings::IDA) {
    checks.Fail(place, "settles the start of a CGα run; IDA, the reference, starts from the scenario as given");
  }
  // A rotor turning at the start settles in the frame spinning with it: at rest there, under
  // the centrifugal loads as well (the blades coned and stiffened), and starts with the frame's
  // rigid rotation.
  const SpinningFrame spin = SpinAtStart(checks, *system, *initial);
  // Coupled: each interface point pinned where its contact node starts (the tie rows' imposed
  // values, rotor-sailing paper Eq. (6)), so the smooth model settles on the nodes as on fixed
  // supports; whether the nodes can rest there is checked after the solve.
  std::vector<RestingNode> nodes;
  if (coupled) {
    nodes = ReadRestingNodes(checks, *system, time_, spin);
    ImposeNodes(nodes, spin);
  }
  EquilibriumOptions options;
  options.t = time_;
  options.tolerance = numerics_.smooth().newton_tolerance();
  options.max_iterations = std::max(50, numerics_.smooth().newton_max_iterations());
  options.stable = true;
  EquilibriumResult r = SettleSolve(*system, initial->q, spin, options);
  settle_iterations_ = r.iterations;
  if (coupled) {
    SettleNodes(*system, spin, options, &nodes, &r);
    // The nodes' start, where they rest: the imposed values (the coordinator tells the contact
    // processes, Hello.node_positions), turning with the frame.
    ImposeNodes(nodes, spin);
    std::vector<Eigen::Vector3d> forces;
    for (size_t k = 0; k < nodes.size(); ++k)
      forces.push_back(system->InterfaceReaction(static_cast<int>(k), r.lambda));
    CheckNodesRest(checks, nodes, forces);
  }
  // The settled configuration as the start, as solved: a position projection would close the
  // regularised coupling rows exactly (Φ = 0 instead of Φ = cλ), pulling each interface point
  // back by its tie's stretch through every coordinate at once (observed: a 2.8e5 N spurious shear
  // in the Puma blade's first beam element). Velocities: the frame's rigid rotation (zero at
  // rest) made consistent with the drives, then the accelerations and multipliers, and the
  // elements' memories from there.
  system->q0 = r.q;
  system->qdot0 = SpinningVelocity(*system, r.q, spin);
  system->AcceptStep(system->q0, system->qdot0, time_, data_.get());
  DaeState settled;
  settled.q = r.q;
  settled.qdot = system->qdot0;
  ProjectVelocities(*system, *data_, time_, &settled);
  ConsistentAccelerations(*system, *data_, time_, &settled);
  *initial = settled;
}

void MultibodySimulation::ImposeNodes(const std::vector<RestingNode>& nodes, const SpinningFrame& spin) {
  for (size_t k = 0; k < nodes.size(); ++k) {
    const Eigen::Vector3d rate = spin.omega.cross(nodes[k].position - spin.origin);
    const Eigen::Vector3d acceleration = spin.omega.cross(rate);
    for (size_t j = 0; j < 3; ++j) {
      ImposedCoordinate& x = data_->imposed[3 * k + j];
      x.value = nodes[k].position(static_cast<Eigen::Index>(j));
      x.rate = rate(static_cast<Eigen::Index>(j));
      x.acceleration = acceleration(static_cast<Eigen::Index>(j));
    }
  }
}

void MultibodySimulation::SettleNodes(const MultibodySystem& system, const SpinningFrame& spin,
                                      EquilibriumOptions options, std::vector<RestingNode>* nodes,
                                      EquilibriumResult* r) {
  // A node that cannot rest where it starts moves: along the frictionless planes that carry it
  // (a pad pulled along its stop by its own weight or spin, by its tie's stretch), or anywhere
  // off the planes that would have to pull it (a pad in mid-air hangs on its tie). Its position
  // becomes an unknown of the equilibrium with its balance along those directions; a plane it
  // would pass through carries it from then on. Rounds until the planes each node rests on
  // stop changing (each round changes one node's planes at least, so a few suffice).
  std::vector<RestingNode>& all = *nodes;
  std::vector<std::vector<int>> sliding_on(nodes->size());  // planes carrying a moving node
  std::vector<char> moving(nodes->size(), 0);
  std::vector<std::vector<int>> guard_plane;  // per entry of options.sliding: its guards' planes
  const int rounds = 4 * static_cast<int>(nodes->size()) + 4;
  for (int round = 0; round <= rounds; ++round) {
    bool changed = false;
    if (r->blocked_node >= 0) {  // stopped where a moving node met a plane: that plane carries it
      const size_t k = static_cast<size_t>(options.sliding[static_cast<size_t>(r->blocked_node)].point);
      sliding_on[k].push_back(guard_plane[static_cast<size_t>(r->blocked_node)][static_cast<size_t>(r->blocked_guard)]);
      std::sort(sliding_on[k].begin(), sliding_on[k].end());
      changed = true;
    }
    for (size_t k = 0; k < nodes->size() && r->blocked_node < 0; ++k) {
      const Eigen::Vector3d force = system.InterfaceReaction(static_cast<int>(k), r->lambda);
      std::vector<int> carrying;
      Eigen::VectorXd push;
      const std::string why = WhyNotResting(all[k], force, 1e-6, &carrying, &push);
      bool frictionless = true;
      for (int i : carrying) frictionless = frictionless && all[k].planes[static_cast<size_t>(i)].friction == 0.0;
      const bool starts = !moving[k];
      if (starts && (why.empty() || !frictionless)) continue;  // rests, or sticks or slips on friction: judged below
      // The planes that push it keep carrying it; those that would pull let it go; the
      // deepest it passed through takes it.
      std::vector<int> keep;
      const double tolerance = 1e-3 * (force + all[k].load).norm() + 1e-6;
      for (size_t i = 0; i < carrying.size(); ++i) {
        if (push(static_cast<Eigen::Index>(i)) >= -tolerance) keep.push_back(carrying[i]);
      }
      int deepest = -1;
      for (size_t i = 0; i < all[k].planes.size(); ++i) {
        const double gap = all[k].planes[i].gap;
        if (gap < -1e-6 && (deepest < 0 || gap < all[k].planes[static_cast<size_t>(deepest)].gap))
          deepest = static_cast<int>(i);
      }
      if (deepest >= 0 && std::find(keep.begin(), keep.end(), deepest) == keep.end()) keep.push_back(deepest);
      std::sort(keep.begin(), keep.end());
      if (!starts && keep == sliding_on[k]) continue;
      moving[k] = 1;
      sliding_on[k] = keep;
      changed = true;
    }
    if (!changed) break;
    options.sliding.clear();
    guard_plane.clear();
    for (size_t k = 0; k < nodes->size(); ++k) {
      if (!moving[k]) continue;
      SlidingNode s;
      s.point = static_cast<int>(k);
      all[k].MoveTo(OnPlanes(all[k], sliding_on[k]));
      s.base = all[k].position;
      s.directions = FreeDirections(all[k], sliding_on[k]);
      s.load = all[k].load;
      s.stiffness = all[k].stiffness;
      guard_plane.emplace_back();
      for (size_t i = 0; i < all[k].planes.size(); ++i) {  // the planes it is free of guard it
        if (std::find(sliding_on[k].begin(), sliding_on[k].end(), static_cast<int>(i)) != sliding_on[k].end()) continue;
        s.guards.emplace_back(all[k].planes[i].point, all[k].planes[i].normal);
        guard_plane.back().push_back(static_cast<int>(i));
      }
      options.sliding.push_back(s);
      for (int j = 0; j < 3; ++j) data_->imposed[3 * k + static_cast<size_t>(j)].value = s.base(j);
    }
    *r = SettleSolve(system, r->q, spin, options);
    settle_iterations_ += r->iterations;
    for (size_t i = 0; i < options.sliding.size(); ++i) {
      all[static_cast<size_t>(options.sliding[i].point)].MoveTo(r->node_positions[i]);
    }
  }
  if (r->blocked_node >= 0) {
    throw NumericalError("numerics.smooth.settle: the contact nodes found no planes to rest on after " +
                         std::to_string(rounds) + " rounds of the settle (each meeting another plane): remove settle");
  }
}

EquilibriumResult MultibodySimulation::SettleSolve(const MultibodySystem& system, const Eigen::VectorXd& q_guess,
                                                   const SpinningFrame& spin, const EquilibriumOptions& options) {
  EquilibriumResult r = StaticEquilibrium(system, data_.get(), q_guess, spin, options);
  if (r.converged || r.blocked_node >= 0) return r;
  std::string moving;
  for (const SlidingNode& node : options.sliding)
    moving += (moving.empty() ? "" : ", ") +
              ("'" + system.interface_points[static_cast<size_t>(node.point)].contact_node + "'");
  if (r.singular && r.iterations == 0) {
    // Nothing holds some part of the model where it starts, even in pseudo-time (its tangent is
    // singular with the pseudo-mass): a scene without a rest to settle into is bad input for
    // settle (tied_drop settled: a body on a tie to a node in mid-air ended 3, "no static
    // equilibrium (residual 9.81 after 0 Newton iterations)").
    throw InputError(
        "numerics.smooth.settle: nothing holds the model at rest where it starts: its equilibrium's tangent is "
        "singular" +
        (moving.empty()
             ? std::string(" (a body or mechanism free to move under its loads: no joint or stop holds it)")
             : " (contact nodes " + moving + " rest on no plane, so nothing holds them or what hangs on them)") +
        "; hold it, start it on its stop, or remove settle");
  }
  throw NumericalError(
      "numerics.smooth.settle: no static equilibrium at t = " + interface::FormatNumber(time_) + " s" +
      (spin.omega.isZero() ? std::string() : " in the frame spinning with the rotor") +
      (moving.empty() ? std::string() : " with contact nodes " + moving + " free to move off their start") + " " +
      ResidualsText(r) +
      "; the scene may have no equilibrium at rest (a free body, a load no stop holds): remove settle" +
      MoreIterationsAdvice(r));
}

SpinningFrame MultibodySimulation::SpinAtStart(const Checks& checks, const MultibodySystem& system,
                                               const DaeState& initial) const {
  // The revolute joint to the ground, or to a moving base (at rest at the start: a shaft on a
  // deck), that turns at the start (a rotor's shaft, driven or spinning freely): its moving
  // body's angular velocity, about the joint's point (the point's place at the start).
  auto fixed = [&](int body) {
    return body < 0 ||
           std::find(model_.base_bodies.begin(), model_.base_bodies.end(), body) != model_.base_bodies.end();
  };
  SpinningFrame spin;
  std::string found;
  for (size_t j = 0; j < model_.joints.size(); ++j) {
    const JointMeasure& m = system.joints[j];
    if (!m.rotational || fixed(m.body1) == fixed(m.body2)) continue;
    if (std::abs(system.JointRate(static_cast<int>(j), initial.q, initial.qdot)) <= 1e-12) continue;
    const Joint& joint = model_.joints[j];
    if (!found.empty()) {
      checks.Fail("numerics.smooth.settle",
                  "joints '" + found + "' and '" + joint.name +
                      "' both turn against the ground at the start; a settled start spins with one rotor: start "
                      "the others at rest, or remove settle");
    }
    found = joint.name;
    const bool fixed_first = fixed(m.body1);
    const int moving = fixed_first ? m.body2 : m.body1;
    spin.omega = BodyAngularRate(initial.q, initial.qdot, moving);
    // The joint's point as it is at the start, a point of the turning body on the axis.
    const Eigen::Vector3d at = joint.body_points
                                   ? (fixed_first ? joint.point2 : joint.point1)
                                   : BodyAxes(system.q0, moving).transpose() *
                                         (joint.point - system.q0.segment<3>(kCoordinatesPerBody * moving));
    spin.origin = initial.q.segment<3>(kCoordinatesPerBody * moving) + BodyAxes(initial.q, moving) * at;
  }
  return spin;
}

void MultibodySimulation::StaticStep(double t1) {
  // The equilibrium with the loads, drives and prescribed motions of t1, from the last one (or
  // the initial configuration): a continuation in the scene's own time functions, which ramp
  // large loads. The probes read it as they read an interpolated state (rates zero).
  const DaeState& from = interpolated_ ? shown_ : integrator_->state();
  EquilibriumOptions options;
  options.t = t1;
  options.tolerance = numerics_.smooth().newton_tolerance();
  options.max_iterations = numerics_.smooth().newton_max_iterations();
  options.stable = true;
  const EquilibriumResult r = StaticEquilibrium(*system_, data_.get(), from.q, SpinningFrame{}, options);
  if (!r.converged) {
    throw NumericalError("STATIC: no equilibrium at t = " + interface::FormatNumber(t1) + " s " + ResidualsText(r) +
                         "; ramp the loads over more steps with their time functions" + MoreIterationsAdvice(r));
  }
  shown_.q = r.q;
  shown_.qdot = Eigen::VectorXd::Zero(r.q.size());
  shown_.qddot = Eigen::VectorXd::Zero(r.q.size());
  shown_.lambda = r.lambda;
  interpolated_ = true;
  newton_.Add(r.iterations);
  time_ = probe_time_ = t1;
  ++steps_;
  max_violation_ = std::max(max_violation_, Violation(shown_.q));
  UnwrapAngles(shown_.q);
}

void MultibodySimulation::UnwrapAngles(const Eigen::VectorXd& q) {
  // Revolute angles unwrapped across ±π (a step never turns a joint by π).
  for (size_t j = 0; j < model_.joints.size(); ++j) {
    if (!system_->joints[j].rotational) continue;
    const double angle = system_->JointCoordinate(static_cast<int>(j), q);
    const double jump = angle - last_angle_[j];
    if (jump > std::numbers::pi) angle_offset_[j] -= 2.0 * std::numbers::pi;
    if (jump < -std::numbers::pi) angle_offset_[j] += 2.0 * std::numbers::pi;
    last_angle_[j] = angle;
  }
}

void MultibodySimulation::Record(double t1, int iterations) {
  system_->AcceptStep(integrator_->state().q, integrator_->state().qdot, t1, data_.get());
  if (ida_) {
    ida_steps_ += iterations;  // IDA's internal steps
  } else {
    newton_.Add(iterations);
  }
  last_step_ = t1 - time_;
  time_ = t1;
  probe_time_ = t1;  // the probes read the integrator's state (an adaptive step may interpolate after)
  interpolated_ = false;
  watchdog_->Check(integrator_->state(), t1, ++steps_);
  max_violation_ = std::max(max_violation_, integrator_->ConstraintViolation(time_));
  UnwrapAngles(integrator_->state().q);
}

void MultibodySimulation::BeginOutput(const std::string& folder) { output_folder_ = folder; }

void MultibodySimulation::WriteFinalState(const std::function<void(state::SmoothState*)>& extend) {
  if (output_folder_.empty()) return;
  state::SmoothState saved;
  saved.set_scenario(scenario_name_);
  saved.set_time(time_);
  saved.set_coordinates(system_->coordinates);
  saved.set_constraints(system_->constraints.size());
  const DaeState& s = static_ ? shown_ : integrator_->state();  // STATIC: the last equilibrium, at rest
  saved.mutable_q()->Add(s.q.data(), s.q.data() + s.q.size());
  saved.mutable_qdot()->Add(s.qdot.data(), s.qdot.data() + s.qdot.size());
  saved.mutable_angle_offsets()->Add(angle_offset_.begin(), angle_offset_.end());
  saved.mutable_reference_q()->Add(reference_q_.data(), reference_q_.data() + reference_q_.size());
  saved.set_reference_time(reference_time_);
  WriteData(*data_, &saved);
  if (cg_ != nullptr && !static_) {
    CgAlpha::Checkpoint history;
    cg_->SaveTo(&history);
    WriteCgAlphaHistory(history, HistoryOf{last_step_, cg_->settings(), adaptive()}, &saved);
    if (adaptive()) saved.set_next_step(adaptive_.next_step());
  }
  if (extend) extend(&saved);
  interface::WriteFinalState(output_folder_, saved);
}

void MultibodySimulation::FillSummary(run::RunSummary* summary) const {
  summary->mutable_numerics()->CopyFrom(numerics_);
  newton_.Fill(summary->mutable_newton_iterations());
  summary->set_max_constraint_violation(max_violation_);
  auto& counters = *summary->mutable_counters();
  counters["bodies"] = static_cast<double>(model_.bodies.size());
  counters["coordinates"] = static_cast<double>(system_->coordinates);
  counters["constraints"] = static_cast<double>(system_->constraints.size());
  counters["initial_kinsol_iterations"] = static_cast<double>(initial_report_.kinsol_iterations);
  if (numerics_.smooth().settle()) counters["settle_newton_iterations"] = static_cast<double>(settle_iterations_);
  counters["initial_position_change"] = initial_report_.position_change;
  counters["initial_velocity_change"] = initial_report_.velocity_change;
  if (!adaptive() && cg_ != nullptr) counters["steps_retried"] = static_cast<double>(retried_steps_);
  if (ida_) counters["ida_internal_steps"] = static_cast<double>(ida_steps_);
  if (adaptive()) {
    counters["adaptive_accepted_steps"] = static_cast<double>(adaptive_.accepted());
    counters["adaptive_rejected_steps"] = static_cast<double>(adaptive_.rejected());
    counters["adaptive_smallest_step"] = adaptive_.smallest_step();
    counters["adaptive_largest_step"] = adaptive_.largest_step();
  }
  if (const CgAlpha* cg = cg_) {
    counters["position_projection_solves"] = static_cast<double>(cg->projection_solves());
    counters["newton_factorizations"] = static_cast<double>(cg->factorizations());
    counters["newton_factor_entries"] = static_cast<double>(cg->factor_entries());  // L + U
  }
  counters["watchdog_max_rigidity_rate"] = watchdog_->max_rigidity_rate();
  counters["watchdog_energy_checked"] = watchdog_->energy_checked() ? 1.0 : 0.0;
  if (watchdog_->energy_checked()) counters["watchdog_max_energy_growth"] = watchdog_->max_energy_growth();
}

}  // namespace cosim::smooth
