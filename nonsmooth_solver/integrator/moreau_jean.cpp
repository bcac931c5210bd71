#include "nonsmooth_solver/integrator/moreau_jean.h"

#include <algorithm>

#include "interface/run/errors.h"
#include "interface/scenario/checks.h"

namespace cosim::nonsmooth {

MoreauJean::MoreauJean(const ContactModel& model, double start_time)
    : model_(model), lcp_(model.lcp), time_(start_time) {
  const Eigen::Index n = static_cast<Eigen::Index>(model.nodes.size());
  const Eigen::Index nc = static_cast<Eigen::Index>(model.contacts.size());
  q_.resize(3 * n);
  v_.resize(3 * n);
  for (Eigen::Index i = 0; i < n; ++i) {
    q_.segment<3>(3 * i) = model.nodes[static_cast<size_t>(i)].position;
    v_.segment<3>(3 * i) = model.nodes[static_cast<size_t>(i)].velocity;
  }
  impulse_ = Eigen::VectorXd::Zero(nc);
  external_ = Eigen::VectorXd::Zero(3 * n);
  v_free_.resize(3 * n);
  mass_hat_.resize(n);
  active_.reserve(static_cast<size_t>(nc));
  W_.resize(nc, nc);
  q_lcp_.resize(nc);
  z_.resize(nc);
  normals_.resize(3, nc);
}

double MoreauJean::Gap(int contact) const {
  const Contact& c = model_.contacts[static_cast<size_t>(contact)];
  return model_.obstacles[static_cast<size_t>(c.obstacle)].Gap(time_, q_.segment<3>(3 * c.node));
}

double MoreauJean::KineticEnergy(int node) const {
  double e = 0.0;
  for (size_t i = 0; i < model_.nodes.size(); ++i) {
    if (node >= 0 && static_cast<size_t>(node) != i) continue;
    e += 0.5 * model_.nodes[i].mass * v_.segment<3>(3 * static_cast<Eigen::Index>(i)).squaredNorm();
  }
  return e;
}

double MoreauJean::PotentialEnergy(int node) const {
  double e = 0.0;
  for (size_t i = 0; i < model_.nodes.size(); ++i) {
    if (node >= 0 && static_cast<size_t>(node) != i) continue;
    const ContactNode& nd = model_.nodes[i];
    const Eigen::Vector3d x = q_.segment<3>(3 * static_cast<Eigen::Index>(i));
    e += -nd.mass * model_.gravity.dot(x) + 0.5 * nd.stiffness * (x - nd.anchor).squaredNorm();
  }
  return e;
}

void MoreauJean::Step(double t, double h) {
  const double theta = model_.theta;
  const double t1 = t + h;
  // Free velocities, node by node (Eq. (3a) without reactions).
  for (size_t i = 0; i < model_.nodes.size(); ++i) {
    const ContactNode& nd = model_.nodes[i];
    const Eigen::Index o = 3 * static_cast<Eigen::Index>(i);
    const auto q = q_.segment<3>(o);
    const auto v = v_.segment<3>(o);
    Eigen::Vector3d fe0 = nd.constant_force + external_.segment<3>(o);
    Eigen::Vector3d fe1 = fe0;
    if (nd.has_time_force) {
      for (int c = 0; c < 3; ++c) {
        fe0(c) += nd.force_function[static_cast<size_t>(c)].Value(t);
        fe1(c) += nd.force_function[static_cast<size_t>(c)].Value(t1);
      }
    }
    const Eigen::Vector3d f0 = fe0 - nd.stiffness * (q - nd.anchor) - nd.damping * v;
    const double m_hat = nd.mass + h * theta * nd.damping + h * h * theta * theta * nd.stiffness;
    mass_hat_(static_cast<Eigen::Index>(i)) = m_hat;
    v_free_.segment<3>(o) =
        (nd.mass * v + h * theta * (fe1 - nd.stiffness * (q - nd.anchor + h * (1.0 - theta) * v)) +
         h * (1.0 - theta) * f0) /
        m_hat;
  }

  // Index set: contacts whose predicted gap closes within the step. u_k (the local velocity
  // at the start of the step) is kept for Newton's law.
  active_.clear();
  for (size_t c = 0; c < model_.contacts.size(); ++c) {
    const Contact& ct = model_.contacts[c];
    const Obstacle& ob = model_.obstacles[static_cast<size_t>(ct.obstacle)];
    const Eigen::Vector3d x = q_.segment<3>(3 * ct.node);
    const double u0 = ob.NormalAt(t).dot(v_.segment<3>(3 * ct.node)) + ob.GapRateBias(t, x);
    if (ob.Gap(t, x) + 0.5 * h * u0 <= model_.activation_gap) {
      q_lcp_(static_cast<Eigen::Index>(active_.size())) = ct.restitution * u0;
      active_.push_back(static_cast<int>(c));
    }
  }
  impulse_.setZero();
  stats_.last_step_active = static_cast<int>(active_.size());
  stats_.last_step_lcp_iterations = 0;

  const Eigen::Index na = static_cast<Eigen::Index>(active_.size());
  if (na > 0) {
    // Normals at t + h and the LCP's q = Hᵀ v_free + b + e u_k (Newton's law on
    // w = u_{k+1} + e u_k, Eq. (2)); the plane's motion b evaluated at t + h.
    for (Eigen::Index a = 0; a < na; ++a) {
      const Contact& ca = model_.contacts[static_cast<size_t>(active_[static_cast<size_t>(a)])];
      const Obstacle& ob = model_.obstacles[static_cast<size_t>(ca.obstacle)];
      const Eigen::Vector3d x1 = q_.segment<3>(3 * ca.node) + h * v_.segment<3>(3 * ca.node);
      normals_.col(a) = ob.NormalAt(t1);
      q_lcp_(a) += normals_.col(a).dot(v_free_.segment<3>(3 * ca.node)) + ob.GapRateBias(t1, x1);
    }
    // Delassus operator W = Hᵀ M̂⁻¹ H (Eq. (5)): contacts couple only through a shared node.
    for (Eigen::Index a = 0; a < na; ++a) {
      const int node_a = model_.contacts[static_cast<size_t>(active_[static_cast<size_t>(a)])].node;
      for (Eigen::Index b = 0; b < na; ++b) {
        const int node_b = model_.contacts[static_cast<size_t>(active_[static_cast<size_t>(b)])].node;
        W_(a, b) = node_a == node_b ? normals_.col(a).dot(normals_.col(b)) / mass_hat_(node_a) : 0.0;
      }
    }
    auto W = W_.topLeftCorner(na, na);
    auto z = z_.head(na);
    const LcpResult result = lcp_.Solve(W, q_lcp_.head(na), z);
    ++stats_.lcp_solves;
    stats_.lcp_iterations += result.iterations;
    stats_.last_step_lcp_iterations = result.iterations;
    stats_.max_step_lcp_iterations = std::max(stats_.max_step_lcp_iterations, result.iterations);
    if (result.used_fallback) ++stats_.lcp_fallbacks;
    if (!result.solved) {
      std::string names;
      for (Eigen::Index a = 0; a < na; ++a) {
        names += (a ? ", " : "") + model_.contacts[static_cast<size_t>(active_[static_cast<size_t>(a)])].name;
      }
      throw NumericalError("LCP of " + std::to_string(na) + " active contact(s) [" + names +
                           "] failed: " + result.message);
    }
    stats_.activations += na;
    for (Eigen::Index a = 0; a < na; ++a) {
      const Contact& ca = model_.contacts[static_cast<size_t>(active_[static_cast<size_t>(a)])];
      v_free_.segment<3>(3 * ca.node) += normals_.col(a) * (z(a) / mass_hat_(ca.node));
      impulse_(active_[static_cast<size_t>(a)]) = z(a);
    }
  }
  // v_free_ now holds v_{k+1}.
  q_ += h * (theta * v_free_ + (1.0 - theta) * v_);
  v_.swap(v_free_);
  time_ = t1;
}

}  // namespace cosim::nonsmooth
