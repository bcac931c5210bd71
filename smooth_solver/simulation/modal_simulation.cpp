#include "smooth_solver/simulation/modal_simulation.h"

#include <array>
#include <cinttypes>
#include <cmath>
#include <string>

#include "interface/base/errors.h"
#include "interface/scenario/checks.h"
#include "smooth_solver/constraints/bilinear_constraints.h"

namespace cosim::smooth {

namespace sc = cosim::scenario;

ModalSimulation::ModalSimulation(const interface::ScenarioFile& file) : model_(BuildMultibodyModel(file)) {
  const interface::Checks checks(file);
  numerics_ = file.proto().numerics();
  const sc::ModesSettings& m = numerics_.smooth().modes();
  axis_ = m.axis_size() == 0 ? Eigen::Vector3d::UnitZ() : checks.Direction("numerics.smooth.modes.axis", m.axis());
  origin_ = checks.Vector3("numerics.smooth.modes.origin", m.origin(), Eigen::Vector3d::Zero());
  if (m.count() < 1 || m.count() > 1000) {
    checks.Fail("numerics.smooth.modes.count", "expected 1 to 1000 modes, got " + std::to_string(m.count()));
  }
  count_ = m.count();
  if (m.ramp_steps() < 1 || m.ramp_steps() > 10000) {
    checks.Fail("numerics.smooth.modes.ramp_steps", "expected 1 to 10000, got " + std::to_string(m.ramp_steps()));
  }
  ramp_steps_ = m.ramp_steps();
  if (!file.proto().model().elastic_bodies().empty()) {
    checks.Fail("model.elastic_bodies", "a MODES analysis takes rigid bodies and beams (hex27 bodies: not yet)");
  }
  if (file.proto().coupling().interface_nodes_size() > 0) {
    checks.Fail("coupling.interface_nodes", "a MODES analysis is of the smooth model alone; leave the coupling out");
  }
  if (file.proto().output().probes_size() > 0) {
    checks.Fail("output.probes", "a MODES analysis writes the modes' frequencies as its columns; leave probes out");
  }
  if (file.proto().output().visual().every() > 0) {
    // (Its frames were written empty, which meshio 5 cannot open.)
    checks.Fail("output.visual.every",
                "a MODES analysis sweeps the spin speed and has no motion to draw; leave "
                "visual output out (0)");
  }
  if (numerics_.smooth().settle()) {  // (it was ignored in silence; STATIC refuses it too)
    checks.Fail("numerics.smooth.settle",
                "settles the start of a DYNAMIC analysis; a MODES analysis finds its own steady state at each "
                "spin speed: remove it");
  }
  if (numerics_.start_time() < 0.0) {
    checks.Fail("numerics.start_time", "is the first spin speed in a MODES analysis; expected >= 0 rad/s, got " +
                                           interface::FormatNumber(numerics_.start_time()));
  }
  system_ = std::make_unique<MultibodySystem>(BuildMultibodySystem(model_));
  data_ = MakeData(*system_);
  q_ = system_->q0;
  // The steady state at the first speed, reached by ramping Ω.
  for (int k = 1; k < ramp_steps_; ++k) Solve(numerics_.start_time() * k / ramp_steps_);
  pending_.clear();
  pending_speed_.clear();
  Solve(numerics_.start_time());
  if (modes_.size() < static_cast<size_t>(count_)) {
    // (More modes asked than the model has: their columns were NaN, and the run ended 3, "no
    // longer finite", with no row written.)
    checks.Fail("numerics.smooth.modes.count", "asks for " + std::to_string(count_) + " modes; the model has " +
                                                   std::to_string(modes_.size()) + " oscillating modes at " +
                                                   interface::FormatNumber(numerics_.start_time()) +
                                                   " rad/s: ask for at most " + std::to_string(modes_.size()));
  }
}

void ModalSimulation::Solve(double omega) {
  SpinningFrame frame;
  frame.omega = omega * axis_;
  frame.origin = origin_;
  EquilibriumOptions options;
  options.t = 0.0;
  options.tolerance = 1e-10;
  options.max_iterations = 200;  // capped steps (EquilibriumOptions::max_step) may need more
  const EquilibriumResult r = StaticEquilibrium(*system_, &data_, q_, frame, options);
  newton_total_ += r.iterations;
  ++solves_;
  if (!r.converged) {
    throw NumericalError("MODES: no steady state found at Ω = " + interface::FormatNumber(omega) + " rad/s " +
                         ResidualsText(r) +
                         "; smaller speed steps, or modes.ramp_steps, or a scene with a static "
                         "equilibrium (an articulated blade with gravity has none at rest)");
  }
  q_ = r.q;
  omega_ = omega;
  modes_.clear();
  for (const Mode& mode : LinearModes(*system_, data_, r.q, r.lambda, 0.0, frame, count_)) {
    modes_.push_back(Classify(r.q, mode));
  }
  pending_.push_back(modes_);
  pending_speed_.push_back(omega);
}

ModalSimulation::Classified ModalSimulation::Classify(const Eigen::VectorXd& q, const Mode& mode) const {
  // The mode's shape split into four motions per node (x, d1, d2, d3 or a body's x, u, v, w):
  // its point along the axis (flap), tangential (lag) and radial, and the turn of its directors
  // about the radial direction through it (torsion: θ = ½ Σ_i d_i × δd_i, BodyAngularRate of the
  // shape, the small rotation of an orthonormal triad, whose radial part turns each d_i by
  // θ_r r̂ × d_i). Shares of the kinetic energy δqᵀ M δq of the four parts: a twist moves no node
  // point, so shares of the point motion alone called the Puma blade's torsion mode "flap".
  const int n = system_->coordinates;
  std::array<Eigen::VectorXd, 4> part;
  for (Eigen::VectorXd& v : part) v = Eigen::VectorXd::Zero(n);
  for (int body = 0; body < n / kCoordinatesPerBody; ++body) {
    const int o = kCoordinatesPerBody * body;
    const Eigen::Vector3d x = q.segment<3>(o) - origin_;
    Eigen::Vector3d radial = x - x.dot(axis_) * axis_;
    if (radial.norm() <= 1e-12) continue;  // on the axis: no radial direction to split along
    radial.normalize();
    const Eigen::Vector3d tangential = axis_.cross(radial);
    const Eigen::Vector3d d = mode.shape.segment<3>(o);
    part[0].segment<3>(o) = d.dot(axis_) * axis_;
    part[1].segment<3>(o) = d.dot(tangential) * tangential;
    part[2].segment<3>(o) = d.dot(radial) * radial;
    const double twist = BodyAngularRate(q, mode.shape, body).dot(radial);
    const Eigen::Matrix3d directors = BodyAxes(q, body);
    for (int i = 0; i < 3; ++i) part[3].segment<3>(o + 3 + 3 * i) = twist * radial.cross(directors.col(i));
  }
  std::array<double, 4> energy;
  double total = 0.0;
  for (size_t k = 0; k < 4; ++k) total += energy[k] = part[k].dot(system_->mass * part[k]);
  if (total > 0.0) {
    for (double& e : energy) e /= total;
  }
  Classified c;
  c.mode = mode;
  c.flap = energy[0], c.lag = energy[1], c.radial = energy[2], c.torsion = energy[3];
  return c;
}

std::vector<std::string> ModalSimulation::ProbeNames() const {
  std::vector<std::string> names;
  for (int k = 1; k <= count_; ++k) names.push_back("mode" + std::to_string(k) + "_frequency");
  return names;
}

void ModalSimulation::Probe(std::vector<double>* values) const {
  for (size_t k = 0; k < values->size(); ++k) {
    (*values)[k] = k < modes_.size() ? modes_[k].mode.frequency : std::nan("");
  }
}

void ModalSimulation::Step(double t, double h) {
  Solve(t + h);
  WritePending();
}

void ModalSimulation::WritePending() {
  if (csv_ == nullptr) return;
  for (size_t s = 0; s < pending_.size(); ++s) {
    for (size_t k = 0; k < pending_[s].size(); ++k) {
      const Classified& c = pending_[s][k];
      const double omega = pending_speed_[s];
      std::fprintf(csv_->get(), "%.17g,%zu,%.17g,%.17g,%.17g,%.6f,%.6f,%.6f,%.6f\n", omega, k + 1, c.mode.frequency,
                   c.mode.damping, omega > 0.0 ? c.mode.frequency / omega : std::nan(""), c.flap, c.lag, c.radial,
                   c.torsion);
    }
    csv_->EndRow();
  }
  pending_.clear();
  pending_speed_.clear();
}

void ModalSimulation::BeginOutput(const std::string& folder) {
  csv_ = std::make_unique<interface::OutputFile>(folder + "/modes.csv");
  std::fprintf(csv_->get(),
               "speed,mode,frequency,damping_ratio,per_rev,flap_share,lag_share,radial_share,torsion_share\n");
  csv_->EndRow();
  // The first speed's modes (solved at construction) go out with the first step.
}

void ModalSimulation::EndOutput() {
  if (csv_ == nullptr) return;
  WritePending();  // a run of one speed has taken no step
  const bool ok = csv_->Flush();
  const std::string error = csv_->error();
  csv_.reset();
  if (!ok) throw InputError(error);
}

void ModalSimulation::FillSummary(run::RunSummary* summary) const {
  summary->mutable_numerics()->CopyFrom(numerics_);
  auto& counters = *summary->mutable_counters();
  counters["speeds_solved"] = solves_;
  counters["steady_state_newton_iterations"] = static_cast<double>(newton_total_);
  counters["coordinates"] = system_->coordinates;
  counters["constraints"] = system_->constraints.size();
  counters["last_speed"] = omega_;
}

}  // namespace cosim::smooth
