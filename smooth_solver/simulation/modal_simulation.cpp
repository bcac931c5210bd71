#include "smooth_solver/simulation/modal_simulation.h"

#include <cinttypes>
#include <cmath>
#include <string>

#include "interface/run/errors.h"
#include "interface/scenario/checks.h"

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
  if (numerics_.start_time() < 0.0) {
    checks.Fail("numerics.start_time", "is the first spin speed in a MODES analysis; expected >= 0 rad/s, got " +
                                           interface::FormatNumber(numerics_.start_time()));
  }
  system_ = std::make_unique<MultibodySystem>(BuildMultibodySystem(model_));
  q_ = system_->q0;
  // The steady state at the first speed, reached by ramping Ω.
  for (int k = 1; k < ramp_steps_; ++k) Solve(numerics_.start_time() * k / ramp_steps_);
  pending_.clear();
  pending_speed_.clear();
  Solve(numerics_.start_time());
}

void ModalSimulation::Solve(double omega) {
  SpinningFrame frame;
  frame.omega = omega * axis_;
  frame.origin = origin_;
  EquilibriumOptions options;
  options.t = 0.0;
  options.tolerance = 1e-10;
  options.max_iterations = 200;  // capped steps (EquilibriumOptions::max_step) may need more
  const EquilibriumResult r = StaticEquilibrium(*system_, q_, frame, options);
  newton_total_ += r.iterations;
  ++solves_;
  if (!r.converged) {
    throw NumericalError("MODES: no steady state found at Ω = " + interface::FormatNumber(omega) + " rad/s (residual " +
                         interface::FormatNumber(r.residual) + " after " + std::to_string(r.iterations) +
                         " Newton iterations); smaller speed steps, or modes.ramp_steps, or a scene with a static "
                         "equilibrium (an articulated blade with gravity has none at rest)");
  }
  q_ = r.q;
  omega_ = omega;
  modes_.clear();
  for (const Mode& mode : LinearModes(*system_, r.q, r.lambda, 0.0, frame, count_)) {
    Classified c;
    c.mode = mode;
    // Share of the node points' motion along the axis, tangential and radial (about the axis).
    const int triples = system_->coordinates / 3;
    for (int k = 0; k < triples; k += 4) {
      const Eigen::Vector3d x = r.q.segment<3>(3 * k) - origin_;
      const Eigen::Vector3d d = mode.shape.segment<3>(3 * k);
      Eigen::Vector3d radial = x - x.dot(axis_) * axis_;
      radial = radial.norm() > 1e-12 ? Eigen::Vector3d(radial.normalized()) : Eigen::Vector3d::Zero();
      const Eigen::Vector3d tangential = axis_.cross(radial);
      c.flap += std::pow(d.dot(axis_), 2);
      c.radial += std::pow(d.dot(radial), 2);
      c.lag += std::pow(d.dot(tangential), 2);
    }
    const double total = c.flap + c.lag + c.radial;
    if (total > 0.0) c.flap /= total, c.lag /= total, c.radial /= total;
    modes_.push_back(c);
  }
  pending_.push_back(modes_);
  pending_speed_.push_back(omega);
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
      std::fprintf(csv_->get(), "%.17g,%zu,%.17g,%.17g,%.17g,%.6f,%.6f,%.6f\n", omega, k + 1, c.mode.frequency,
                   c.mode.damping, omega > 0.0 ? c.mode.frequency / omega : std::nan(""), c.flap, c.lag, c.radial);
    }
    csv_->EndRow();
  }
  pending_.clear();
  pending_speed_.clear();
}

void ModalSimulation::BeginOutput(const std::string& folder) {
  csv_ = std::make_unique<interface::OutputFile>(folder + "/modes.csv");
  std::fprintf(csv_->get(), "speed,mode,frequency,damping_ratio,per_rev,flap_share,lag_share,radial_share\n");
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
