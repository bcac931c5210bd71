#include "nonsmooth_solver/penalty/penalty_simulation.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <tuple>

#include "interface/base/errors.h"
#include "interface/scenario/checks.h"

namespace cosim::nonsmooth {

namespace sc = scenario;

PenaltySimulation::PenaltySimulation(const interface::ScenarioFile& file, const std::set<std::string>* only_nodes)
    : ContactStepper(file), model_(std::make_unique<const ContactModel>(BuildContactModel(file, only_nodes))) {
  const interface::Checks checks(file);
  numerics_.CopyFrom(file.proto().numerics());
  interface::MaterializeDefaults(&numerics_);
  numerics_.clear_smooth();
  numerics_.clear_nonsmooth();  // Moreau–Jean's settings are not used here
  const sc::PenaltySettings& p = numerics_.penalty();
  checks.Require("numerics.penalty.stiffness", file.proto().numerics().penalty().has_stiffness(),
                 "the contact stiffness K [N/m^n] of penalty_solver's law");
  interface::HuntCrossleyLaw law;
  law.stiffness = checks.Positive("numerics.penalty.stiffness", true, p.stiffness(), "N/m^n");
  law.exponent = checks.Positive("numerics.penalty.exponent", true, p.exponent(), "dimensionless");
  law.speed_threshold = checks.Positive("numerics.penalty.speed_threshold", true, p.speed_threshold(), "m/s");
  if (p.substeps() < 1) {
    checks.Fail("numerics.penalty.substeps", "must be >= 1, got " + std::to_string(p.substeps()));
  }
  substeps_ = p.substeps();
  // Each contact's law rebounds with its Newton e (one bisection per distinct e).
  std::map<double, double> law_restitution;
  for (size_t c = 0; c < model_->contacts.size(); ++c) {
    const Contact& contact = model_->contacts[c];
    if (contact.friction != 0.0) {
      checks.Fail("model.contact_nodes[" + model_->nodes[static_cast<size_t>(contact.node)].name + "].contacts",
                  "contact '" + contact.name + "' has friction " + interface::FormatNumber(contact.friction) +
                      "; penalty_solver is frictionless (use nonsmooth_solver for Coulomb friction)");
    }
    if (!(contact.restitution > 0.0)) {
      checks.Fail(
          "model.contact_nodes[" + model_->nodes[static_cast<size_t>(contact.node)].name + "].contacts",
          "contact '" + contact.name + "' has restitution 0; penalty_solver's law needs e > 0 (it divides by e)");
    }
    auto it = law_restitution.find(contact.restitution);
    if (it == law_restitution.end()) {
      it = law_restitution.emplace(contact.restitution, interface::LawRestitution(contact.restitution, law.exponent))
               .first;
    }
    laws_.push_back(law);
    laws_.back().restitution = it->second;
  }
  const auto n = static_cast<Eigen::Index>(3 * model_->nodes.size());
  const auto m = static_cast<Eigen::Index>(model_->contacts.size());
  state_.time = numerics_.start_time();
  state_.q.resize(n);
  state_.v.resize(n);
  for (size_t i = 0; i < model_->nodes.size(); ++i) {
    state_.q.segment<3>(3 * static_cast<Eigen::Index>(i)) = model_->nodes[i].position;
    state_.v.segment<3>(3 * static_cast<Eigen::Index>(i)) = model_->nodes[i].velocity;
  }
  state_.impact_speed = Eigen::VectorXd::Constant(m, law.speed_threshold);
  state_.impulse = Eigen::VectorXd::Zero(m);
  data_.frames.resize(static_cast<size_t>(model_->driven_frames));
  saved_ = state_;
  external_ = Eigen::VectorXd::Zero(n);
  mass_.resize(n);
  for (size_t i = 0; i < model_->nodes.size(); ++i)
    mass_.segment<3>(3 * static_cast<Eigen::Index>(i)).setConstant(model_->nodes[i].mass);
  for (Eigen::VectorXd* w : {&f0_, &f1_, &q1_, &v1_, &residual_, &dv_}) w->resize(n);
  for (Eigen::VectorXd* w : {&c0_, &c1_}) w->resize(m);
  for (Eigen::MatrixXd* w : {&K_, &C_, &J_}) w->resize(n, n);
}

std::string PenaltySimulation::SolverName() const {
  return "penalty_solver (Hunt-Crossley penalty, implicit trapezoidal rule, " + std::to_string(substeps_) +
         " substep(s) per step)";
}

void PenaltySimulation::Forces(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& v, Eigen::VectorXd* f,
                               Eigen::VectorXd* contact, Eigen::MatrixXd* K, Eigen::MatrixXd* C) const {
  const ContactModel& model = *model_;
  *f = external_;
  if (K != nullptr) {
    K->setZero();
    C->setZero();
  }
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  for (size_t i = 0; i < model.nodes.size(); ++i) {
    const ContactNode& nd = model.nodes[i];
    const auto o = 3 * static_cast<Eigen::Index>(i);
    f->segment<3>(o) += nd.constant_force - nd.stiffness * (q.segment<3>(o) - nd.anchor) - nd.damping * v.segment<3>(o);
    if (nd.has_time_force) {
      for (int c = 0; c < 3; ++c) (*f)(o + c) += nd.force_function[static_cast<size_t>(c)].Value(t);
    }
    if (K != nullptr) {
      K->block<3, 3>(o, o) += nd.stiffness * I;
      C->block<3, 3>(o, o) += nd.damping * I;
    }
  }
  for (const NodeSpring& s : model.springs) {
    const Eigen::Index a = 3 * s.node1, b = 3 * s.node2;
    const Eigen::Vector3d g = -s.stiffness * (q.segment<3>(a) - q.segment<3>(b) - s.rest_offset) -
                              s.damping * (v.segment<3>(a) - v.segment<3>(b));
    f->segment<3>(a) += g;
    f->segment<3>(b) -= g;
    if (K != nullptr) {
      for (const auto& [r, c, sign] : {std::tuple{a, a, 1.0}, {a, b, -1.0}, {b, a, -1.0}, {b, b, 1.0}}) {
        K->block<3, 3>(r, c) += sign * s.stiffness * I;
        C->block<3, 3>(r, c) += sign * s.damping * I;
      }
    }
  }
  for (size_t c = 0; c < model.contacts.size(); ++c) {
    const Contact& ct = model.contacts[c];
    const Obstacle& ob = model.obstacles[static_cast<size_t>(ct.obstacle)];
    const auto o = 3 * static_cast<Eigen::Index>(ct.node);
    const Eigen::Vector3d x = q.segment<3>(o), n = ob.NormalAt(t, data_);
    // δ = −n·(x − p), δ̇ = −(n·ẋ + bias): the force f n pushes the node out along n.
    const double delta = -ob.Gap(t, x, data_), rate = -(n.dot(v.segment<3>(o)) + ob.GapRateBias(t, x, data_));
    const interface::HuntCrossleyForce law =
        interface::EvaluateHuntCrossley(laws_[c], state_.impact_speed(static_cast<Eigen::Index>(c)), delta, rate);
    f->segment<3>(o) += law.f * n;
    (*contact)(static_cast<Eigen::Index>(c)) = law.f;
    if (K != nullptr && law.f > 0.0) {
      K->block<3, 3>(o, o) += law.df_ddelta * n * n.transpose();
      C->block<3, 3>(o, o) += law.df_drate * n * n.transpose();
    }
  }
}

void PenaltySimulation::Substep(double t, double h) {
  const ContactModel& model = *model_;
  const Eigen::VectorXd& q0 = state_.q;
  const Eigen::VectorXd& v0 = state_.v;
  // δ̇⁻: the approach speed of every contact still open at the substep's start.
  for (size_t c = 0; c < model.contacts.size(); ++c) {
    const Contact& ct = model.contacts[c];
    const Obstacle& ob = model.obstacles[static_cast<size_t>(ct.obstacle)];
    const auto o = 3 * static_cast<Eigen::Index>(ct.node);
    const Eigen::Vector3d x = q0.segment<3>(o);
    if (ob.Gap(t, x, data_) >= 0.0) {
      const double rate = -(ob.NormalAt(t, data_).dot(v0.segment<3>(o)) + ob.GapRateBias(t, x, data_));
      state_.impact_speed(static_cast<Eigen::Index>(c)) = std::max(rate, laws_[c].speed_threshold);
    }
  }
  Forces(t, q0, v0, &f0_, &c0_, nullptr, nullptr);
  // Newton on v₁: R = M (v₁ − v₀) − h/2 (f₀ + f₁) = 0, ∂R/∂v₁ = M + h/2 (C + h/2 K).
  v1_ = v0 + h * (f0_.array() / mass_.array()).matrix();  // explicit predictor
  for (int it = 0;; ++it) {
    q1_ = q0 + 0.5 * h * (v0 + v1_);
    Forces(t + h, q1_, v1_, &f1_, &c1_, &K_, &C_);
    residual_ = (mass_.array() * (v1_ - v0).array()).matrix() - 0.5 * h * (f0_ + f1_);
    ++newton_iterations_;
    // Relative to the largest term of R (momenta and impulses), so that round-off always
    // passes: the impulses h f are the large terms of a long step into a stiff contact.
    const double scale =
        std::max({1.0, (mass_.array() * v0.array().abs()).maxCoeff(), (mass_.array() * v1_.array().abs()).maxCoeff(),
                  0.5 * h * f0_.lpNorm<Eigen::Infinity>(), 0.5 * h * f1_.lpNorm<Eigen::Infinity>()});
    if (residual_.lpNorm<Eigen::Infinity>() <= 1e-12 * scale) break;
    // The last correction was at round-off (a stiff contact's h² K amplifies the round-off of
    // v₁ in R beyond the test above): no iteration can do better.
    if (it > 0 && dv_.lpNorm<Eigen::Infinity>() <=
                      64.0 * std::numeric_limits<double>::epsilon() * std::max(1.0, v1_.lpNorm<Eigen::Infinity>())) {
      break;
    }
    if (it == 50 || !residual_.allFinite()) {
      throw NumericalError(
          "penalty_solver: Newton did not converge in the step from t = " + interface::FormatNumber(t) +
          " s (residual " + interface::FormatNumber(residual_.lpNorm<Eigen::Infinity>()) +
          " N s): shorten the step, raise numerics.penalty.substeps or lower numerics.penalty.stiffness");
    }
    J_ = 0.5 * h * (C_ + 0.5 * h * K_);
    J_.diagonal() += mass_;
    dv_ = J_.partialPivLu().solve(residual_);
    v1_ -= dv_;
  }
  state_.q = q1_;
  state_.v = v1_;
  state_.impulse += 0.5 * h * (c0_ + c1_);
  ++substeps_taken_;
}

void PenaltySimulation::Advance(double t, double h) {
  const ContactModel& model = *model_;
  state_.impulse.setZero();
  const double dt = h / substeps_;
  for (int s = 0; s < substeps_; ++s) Substep(t + s * dt, dt);
  state_.time = t + h;
  for (size_t c = 0; c < model.contacts.size(); ++c)
    max_penetration_ = std::max(max_penetration_, -Gap(static_cast<int>(c)));
}

double PenaltySimulation::Gap(int contact) const {
  const Contact& c = model_->contacts[static_cast<size_t>(contact)];
  return model_->obstacles[static_cast<size_t>(c.obstacle)].Gap(state_.time, state_.q.segment<3>(3 * c.node), data_);
}

double PenaltySimulation::GapRate(int contact) const {
  const Contact& c = model_->contacts[static_cast<size_t>(contact)];
  const Obstacle& ob = model_->obstacles[static_cast<size_t>(c.obstacle)];
  const Eigen::Vector3d x = state_.q.segment<3>(3 * c.node);
  return ob.NormalAt(state_.time, data_).dot(state_.v.segment<3>(3 * c.node)) + ob.GapRateBias(state_.time, x, data_);
}

bool PenaltySimulation::Impact(int) const { return false; }  // finite forces: velocities never jump

void PenaltySimulation::FillSummary(run::RunSummary* summary) const {
  summary->mutable_numerics()->CopyFrom(numerics_);
  summary->set_max_constraint_violation(max_penetration_);  // a penalty contact penetrates
  auto& counters = *summary->mutable_counters();
  counters["substeps"] = static_cast<double>(substeps_taken_);
  counters["newton_iterations"] = static_cast<double>(newton_iterations_);
  counters["contact_nodes"] = static_cast<double>(model_->nodes.size());
  counters["contacts"] = static_cast<double>(model_->contacts.size());
  for (size_t c = 0; c < laws_.size(); ++c) {
    counters["law_restitution_" + model_->contacts[c].name] = laws_[c].restitution;
  }
}

void PenaltySimulation::WriteState(state::ContactState* s) const {
  s->mutable_impulse()->Add(state_.impulse.data(), state_.impulse.data() + state_.impulse.size());
  s->mutable_impact_speed()->Add(state_.impact_speed.data(), state_.impact_speed.data() + state_.impact_speed.size());
}

void PenaltySimulation::ReadState(const state::ContactState& s) {
  state_.time = s.time();
  state_.q = Eigen::Map<const Eigen::VectorXd>(s.q().data(), s.q_size());
  state_.v = Eigen::Map<const Eigen::VectorXd>(s.v().data(), s.v_size());
  state_.impulse = Eigen::Map<const Eigen::VectorXd>(s.impulse().data(), s.impulse_size());
  state_.impact_speed.setZero();
  if (s.impact_speed_size() == state_.impact_speed.size()) {
    state_.impact_speed = Eigen::Map<const Eigen::VectorXd>(s.impact_speed().data(), s.impact_speed_size());
  }
  saved_ = state_;
}

}  // namespace cosim::nonsmooth
