#include "nonsmooth_solver/integrator/moreau_jean.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "interface/base/errors.h"
#include "nonsmooth_solver/lcp/friction_contact_solver.h"

namespace cosim::nonsmooth {

namespace {

size_t Idx(int i) { return static_cast<size_t>(i); }

}  // namespace

MoreauJean::MoreauJean(const ContactModel& model, const MoreauJeanSettings& settings, double start_time)
    : model_(model), settings_(settings), lcp_(settings.lcp), time_(start_time) {
  data_.frames.resize(static_cast<size_t>(model.driven_frames));
  const Eigen::Index n = static_cast<Eigen::Index>(model.nodes.size());
  const Eigen::Index nc = static_cast<Eigen::Index>(model.contacts.size());
  q_.resize(3 * n);
  v_.resize(3 * n);
  for (Eigen::Index i = 0; i < n; ++i) {
    q_.segment<3>(3 * i) = model.nodes[Idx(static_cast<int>(i))].position;
    v_.segment<3>(3 * i) = model.nodes[Idx(static_cast<int>(i))].velocity;
  }
  impulse_ = Eigen::VectorXd::Zero(nc);
  friction_impulse_ = Eigen::MatrixXd::Zero(3, nc);
  external_ = Eigen::VectorXd::Zero(3 * n);
  applied_ = external_;
  velocity_sensitivity_ = Eigen::VectorXd::Zero(9 * n);

  // Per group: masses, stiffness and damping matrices, constant spring forces.
  const bool fc3d = settings.friction_model == FrictionModel::kSiconosFc3d;
  int total_columns = 0, total_lambdas = 0;
  work_.resize(model.groups.size());
  for (size_t g = 0; g < model.groups.size(); ++g) {
    const NodeGroup& group = model.groups[g];
    GroupWork& w = work_[g];
    w.dofs = 3 * static_cast<int>(group.nodes.size());
    w.mass.resize(w.dofs);
    w.K = Eigen::MatrixXd::Zero(w.dofs, w.dofs);
    w.C = Eigen::MatrixXd::Zero(w.dofs, w.dofs);
    w.f_rest = Eigen::VectorXd::Zero(w.dofs);
    for (size_t s = 0; s < group.nodes.size(); ++s) {
      const ContactNode& node = model.nodes[Idx(group.nodes[s])];
      const Eigen::Index o = 3 * static_cast<Eigen::Index>(s);
      w.mass.segment<3>(o).setConstant(node.mass);
      // Anchor spring: f = −k (x − a) − c ẋ.
      w.K.block<3, 3>(o, o).diagonal().array() += node.stiffness;
      w.C.block<3, 3>(o, o).diagonal().array() += node.damping;
      w.f_rest.segment<3>(o) += node.stiffness * node.anchor;
    }
    for (const NodeSpring& spring : model.springs) {
      if (model.node_group[Idx(spring.node1)] != static_cast<int>(g)) continue;
      // f₁ = −k (x₁ − x₂ − r₀) − c (ẋ₁ − ẋ₂), f₂ = −f₁.
      const Eigen::Index a = 3 * model.node_slot[Idx(spring.node1)];
      const Eigen::Index b = 3 * model.node_slot[Idx(spring.node2)];
      for (auto [M, value] : {std::pair{&w.K, spring.stiffness}, std::pair{&w.C, spring.damping}}) {
        M->block<3, 3>(a, a).diagonal().array() += value;
        M->block<3, 3>(b, b).diagonal().array() += value;
        M->block<3, 3>(a, b).diagonal().array() -= value;
        M->block<3, 3>(b, a).diagonal().array() -= value;
      }
      w.f_rest.segment<3>(a) += spring.stiffness * spring.rest_offset;
      w.f_rest.segment<3>(b) -= spring.stiffness * spring.rest_offset;
    }
    w.has_linear_forces = !w.K.isZero(0.0) || !w.C.isZero(0.0);
    w.diagonal = w.K.isDiagonal(0.0) && w.C.isDiagonal(0.0);
    w.m_hat_diagonal.resize(w.dofs);
    int columns = 0;
    for (int c : group.contacts) {
      const bool friction = model.contacts[Idx(c)].friction > 0.0;
      columns += fc3d ? 3 : 1 + (friction ? settings.friction_facets : 0);
      total_lambdas += (!fc3d && friction) ? 1 : 0;
    }
    total_columns += columns;
    w.m_hat_matrix.resize(w.dofs, w.dofs);
    for (Eigen::VectorXd* v : {&w.q, &w.v, &w.fe0, &w.fe1, &w.rhs, &w.v_free}) v->resize(w.dofs);
    w.G = Eigen::MatrixXd::Zero(w.dofs, std::max(columns, 1));
    w.Y.resize(w.dofs, std::max(columns, 1));
    all_groups_.push_back(static_cast<int>(g));
  }
  const int size = std::max(total_columns + total_lambdas, 1);
  A_.resize(size, size);
  b_.resize(size);
  z_.resize(size);
  mu_.resize(std::max<Eigen::Index>(nc, 1));
  active_.reserve(Idx(static_cast<int>(nc)));
  first_active_.resize(model.groups.size());
  one_group_.resize(1);
}

double MoreauJean::Gap(int contact) const {
  const Contact& c = model_.contacts[Idx(contact)];
  return model_.obstacles[Idx(c.obstacle)].Gap(time_, q_.segment<3>(3 * c.node), data_);
}

double MoreauJean::GapRate(int contact) const {
  const Contact& c = model_.contacts[Idx(contact)];
  const Obstacle& ob = model_.obstacles[Idx(c.obstacle)];
  const Eigen::Vector3d x = q_.segment<3>(3 * c.node);
  return ob.NormalAt(time_, data_).dot(v_.segment<3>(3 * c.node)) + ob.GapRateBias(time_, x, data_);
}

double MoreauJean::KineticEnergy(int node) const { return nonsmooth::KineticEnergy(model_, v_, node); }

double MoreauJean::PotentialEnergy(int node) const { return nonsmooth::PotentialEnergy(model_, q_, node); }

Eigen::Vector3d MoreauJean::FacetDirection(const Obstacle& ob, double t, int j) const {
  const Eigen::Vector3d n = ob.NormalAt(t, data_), t1 = ob.TangentAt(t, data_);
  const double angle = 2.0 * std::numbers::pi * j / settings_.friction_facets;
  return std::cos(angle) * t1 + std::sin(angle) * n.cross(t1);
}

void MoreauJean::FreeVelocity(int group_index, double t, double h) {
  const double theta = settings_.theta;
  GroupWork& w = work_[Idx(group_index)];
  const NodeGroup& group = model_.groups[Idx(group_index)];
  for (size_t s = 0; s < group.nodes.size(); ++s) {
    const int i = group.nodes[s];
    const ContactNode& nd = model_.nodes[Idx(i)];
    const Eigen::Index o = 3 * static_cast<Eigen::Index>(s);
    w.q.segment<3>(o) = q_.segment<3>(3 * i);
    w.v.segment<3>(o) = v_.segment<3>(3 * i);
    w.fe0.segment<3>(o) = nd.constant_force + external_.segment<3>(3 * i);
    w.fe1.segment<3>(o) = w.fe0.segment<3>(o);
    if (nd.has_time_force) {
      for (int c = 0; c < 3; ++c) {
        w.fe0(o + c) += nd.force_function[Idx(c)].Value(t);
        w.fe1(o + c) += nd.force_function[Idx(c)].Value(t + h);
      }
    }
  }
  if (w.factored_h != h) {
    // M̂ = M + hθC + h²θ²K, factored once per step size (a division when it is diagonal).
    w.m_hat_matrix = h * theta * w.C + h * h * theta * theta * w.K;
    w.m_hat_matrix.diagonal() += w.mass;
    w.m_hat_diagonal = w.m_hat_matrix.diagonal();
    if (!w.diagonal) {
      w.m_hat.compute(w.m_hat_matrix);
      if (w.m_hat.info() != Eigen::Success) {
        throw NumericalError("iteration matrix M + hθC + h²θ²K is not positive definite");
      }
    }
    w.factored_h = h;
    w.m_hat_inverse.resize(0, 0);  // (made when a sensitivity asks for it)
  }
  // The interface stiffness (see the header): −h²θ E on the node's block of M̂, and
  // E (q + h(1−θ) v − x̂) with the held force.
  w.coupled = false;
  if (stiffness_.size() > 0) {
    Eigen::MatrixXd coupled;  // (only while a coordinator sends stiffnesses: small groups)
    for (size_t s = 0; s < group.nodes.size(); ++s) {
      const int i = group.nodes[s];
      const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> E(stiffness_.data() + 9 * i);
      if (E.isZero(0.0)) continue;
      if (!w.coupled) {
        coupled = w.m_hat_matrix;
        w.coupled = true;
      }
      const Eigen::Index o = 3 * static_cast<Eigen::Index>(s);
      coupled.block<3, 3>(o, o) -= (h * h * theta) * E;
      const Eigen::Vector3d f =
          E * (q_.segment<3>(3 * i) + h * (1.0 - theta) * v_.segment<3>(3 * i) - reference_.segment<3>(3 * i));
      w.fe0.segment<3>(o) += f;
      w.fe1.segment<3>(o) += f;
    }
    if (w.coupled) {
      w.m_hat_coupled.compute(coupled);
      if (!(std::abs(w.m_hat_coupled.determinant()) > 0.0) || !std::isfinite(w.m_hat_coupled.determinant())) {
        throw NumericalError(
            "iteration matrix M + hθC + h²θ²K − h²θE with the coordinator's interface stiffness E "
            "is singular");
      }
    }
  }
  // Eq. (3a) without reactions: M̂ v_free = M v + hθ(fe1 + f_r − K(q + h(1−θ)v)) + h(1−θ) f(q, v, t).
  w.rhs = w.mass.cwiseProduct(w.v) + (h * theta) * w.fe1 + (h * (1.0 - theta)) * w.fe0;
  if (w.has_linear_forces) {
    // (v_free serves as scratch for q + h(1−θ)v: no allocation.)
    w.rhs += h * w.f_rest;
    w.v_free = w.q + h * (1.0 - theta) * w.v;
    w.rhs.noalias() -= (h * theta) * (w.K * w.v_free);
    w.rhs.noalias() -= (h * (1.0 - theta)) * (w.K * w.q);
    w.rhs.noalias() -= (h * (1.0 - theta)) * (w.C * w.v);
  }
  w.v_free = w.rhs;
  SolveMHat(w, w.v_free);
}

void MoreauJean::SolveMHat(const GroupWork& w, Eigen::Ref<Eigen::MatrixXd> x) const {
  if (w.coupled) {
    x = w.m_hat_coupled.solve(x);
  } else if (w.diagonal) {
    x = w.m_hat_diagonal.cwiseInverse().asDiagonal() * x;
  } else {
    w.m_hat.solveInPlace(x);
  }
}

void MoreauJean::SetInterfaceStiffness(const Eigen::Ref<const Eigen::VectorXd>& stiffness,
                                       const Eigen::Ref<const Eigen::VectorXd>& reference) {
  COSIM_ASSERT(stiffness.size() == 3 * q_.size() && reference.size() == q_.size(),
               "SetInterfaceStiffness: 9 stiffness values and 3 reference coordinates per node");
  stiffness_ = stiffness;
  reference_ = reference;
}

void MoreauJean::FreeSensitivity(int group, double h) {
  GroupWork& w = work_[Idx(group)];
  if (w.m_hat_inverse.rows() != w.dofs) {
    w.m_hat_inverse = Eigen::MatrixXd::Identity(w.dofs, w.dofs);
    if (w.diagonal) {
      w.m_hat_inverse.diagonal() = w.m_hat_diagonal.cwiseInverse();
    } else {
      w.m_hat.solveInPlace(w.m_hat_inverse);
    }
  }
  const std::vector<int>& nodes = model_.groups[Idx(group)].nodes;
  for (size_t s = 0; s < nodes.size(); ++s) {
    const Eigen::Index o = 3 * static_cast<Eigen::Index>(s);
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(velocity_sensitivity_.data() + 9 * nodes[s]) =
        h * w.m_hat_inverse.block<3, 3>(o, o);
  }
}

// On the piece of the LCP's solution where `z` is (see the header): the impulse rows' basis,
// with A_u the LCP matrix with the uncoupled Delassus block Gᵀ M̂⁻¹ G and ∂b/∂f = Gᵀ V0.
Eigen::MatrixXd MoreauJean::LcpPieceSensitivity(const SensitivityBlocks& b, int size) const {
  const auto z = z_.head(size);
  std::vector<int> basis;
  Eigen::MatrixXd dv;
  for (int i = 0; i < size; ++i) {
    if (z(i) > 0.0) basis.push_back(i);
  }
  const int nb = static_cast<int>(basis.size());
  // A_u: the LCP matrix with the uncoupled Delassus block Gᵀ M̂⁻¹ G; ∂b/∂f = Gᵀ b.V0 (impulse rows).
  Eigen::MatrixXd Abb(nb, nb), dbb = Eigen::MatrixXd::Zero(nb, b.dofs);
  const Eigen::MatrixXd Wu = b.G.transpose() * b.Yu;
  for (int r = 0; r < nb; ++r) {
    const int i = basis[Idx(r)];
    for (int c = 0; c < nb; ++c) {
      const int j = basis[Idx(c)];
      Abb(r, c) = (i < b.columns && j < b.columns) ? Wu(i, j) : A_(i, j);
    }
    if (i < b.columns) dbb.row(r) = b.G.col(i).transpose() * b.V0;
  }
  dv = b.V0;
  if (nb > 0) {
    const Eigen::MatrixXd dz = -Abb.fullPivLu().solve(dbb);
    for (int r = 0; r < nb; ++r) {
      if (basis[Idx(r)] < b.columns) dv += b.Yu.col(basis[Idx(r)]) * dz.row(r);
    }
  }
  return dv;
}

// The same with Coulomb friction (Siconos fc3d): per contact with a normal impulse, sticking fixes
// its three directions; sliding fixes its normal velocity.
Eigen::MatrixXd MoreauJean::Fc3dPieceSensitivity(const std::vector<int>& groups, const SensitivityBlocks& b, int size,
                                                 double t1, double h) const {
  const auto z = z_.head(size);
  Eigen::MatrixXd dv;
  // Per contact with a normal impulse: sticking fixes its three directions; sliding fixes its
  // normal velocity (De Saxcé's modified velocity u_n + μ|u_t| is then μ|u_t|), its impulse r_n (n − μ s) along the
  // sliding direction s = u_t/|u_t| = −r_t/(μ r_n), which turns with the tangential velocity: δ(r_n μ s) = μ
  // r_n/|u_t| (P_t − s sᵀ) δv (P_t = I − n nᵀ), a positive semi-definite term added to M̂.
  Eigen::MatrixXd Mhat = Eigen::MatrixXd::Zero(b.dofs, b.dofs);
  std::vector<Eigen::Index> node_row(model_.nodes.size(), -1);
  {
    int d = 0;
    for (int g : groups) {
      Mhat.block(d, d, work_[Idx(g)].dofs, work_[Idx(g)].dofs) = work_[Idx(g)].m_hat_matrix;
      const std::vector<int>& nodes = model_.groups[Idx(g)].nodes;
      for (size_t k = 0; k < nodes.size(); ++k) node_row[Idx(nodes[k])] = d + 3 * static_cast<Eigen::Index>(k);
      d += work_[Idx(g)].dofs;
    }
  }
  std::vector<Eigen::VectorXd> fixed, along;
  int contact = 0;
  for (int i = 0; i + 2 < b.columns; i += 3, ++contact) {  // (fc3d: three columns a contact, no other rows)
    const double rn = z(i);
    if (!(rn > 0.0)) continue;
    const Eigen::Vector2d rt(z(i + 1), z(i + 2));
    const double mu = mu_(contact);
    if (rt.norm() < mu * rn * (1.0 - 1e-9)) {
      for (int j = 0; j < 3; ++j) {
        fixed.push_back(b.G.col(i + j));
        along.push_back(b.G.col(i + j));
      }
      continue;
    }
    along.push_back(b.G.col(i) + (rt(0) / rn) * b.G.col(i + 1) + (rt(1) / rn) * b.G.col(i + 2));
    // The contact's node and the tangential speed of its end velocity against the plane.
    const ActiveContact* a = nullptr;
    for (const ActiveContact& c : active_) {
      if (work_[Idx(c.group)].column_offset + c.normal_column == i) a = &c;
    }
    COSIM_ASSERT(a != nullptr, "fc3d sensitivity: a column without its contact");
    const Contact& ct = model_.contacts[Idx(a->contact)];
    const Obstacle& ob = model_.obstacles[Idx(ct.obstacle)];
    const GroupWork& w = work_[Idx(a->group)];
    const Eigen::Index o = 3 * model_.node_slot[Idx(ct.node)];
    const Eigen::Vector3d x1 = q_.segment<3>(3 * ct.node) + h * v_.segment<3>(3 * ct.node);
    const Eigen::Vector3d n = ob.NormalAt(t1, data_);
    const Eigen::Vector3d u = w.v_free.segment<3>(o) - ob.VelocityAt(t1, x1, data_);  // (v_free holds v_{k+1})
    const Eigen::Vector3d ut = u - n.dot(u) * n;
    fixed.push_back(b.G.col(i));
    if (!(ut.norm() > 0.0)) continue;
    const Eigen::Vector3d sliding = ut.normalized();
    const Eigen::Matrix3d Pt = Eigen::Matrix3d::Identity() - n * n.transpose();
    Mhat.block<3, 3>(node_row[Idx(ct.node)], node_row[Idx(ct.node)]) +=
        (mu * rn / ut.norm()) * (Pt - sliding * sliding.transpose());
  }
  const Eigen::MatrixXd Minv = Mhat.inverse();
  dv = h * Minv;
  const int nb = static_cast<int>(fixed.size());
  if (nb > 0) {
    Eigen::MatrixXd C(nb, b.dofs), D(b.dofs, nb);
    for (int k = 0; k < nb; ++k) {
      C.row(k) = fixed[Idx(k)].transpose();
      D.col(k) = along[Idx(k)];
    }
    const Eigen::MatrixXd YD = Minv * D;
    dv -= YD * (C * YD).fullPivLu().solve(C * dv);
  }
  return dv;
}

void MoreauJean::ContactSensitivity(const std::vector<int>& groups, int size, double t1, double h) {
  // On the piece of the LCP's solution (see the header), for a constant force on the nodes (the
  // uncoupled M̂): dv = V0 + Y_u dz, V0 = h M̂⁻¹, Y_u = M̂⁻¹ G, over the groups' dofs together.
  SensitivityBlocks b;
  for (int g : groups) {
    FreeSensitivity(g, h);  // (makes m_hat_inverse)
    b.dofs += work_[Idx(g)].dofs;
  }
  b.V0 = Eigen::MatrixXd::Zero(b.dofs, b.dofs);
  b.Yu = Eigen::MatrixXd::Zero(b.dofs, size);
  b.G = Eigen::MatrixXd::Zero(b.dofs, size);
  {
    int d = 0;
    for (int g : groups) {
      const GroupWork& w = work_[Idx(g)];
      b.V0.block(d, d, w.dofs, w.dofs) = h * w.m_hat_inverse;
      b.G.block(d, w.column_offset, w.dofs, w.columns) = w.G.leftCols(w.columns);
      b.Yu.block(d, w.column_offset, w.dofs, w.columns) = w.m_hat_inverse * w.G.leftCols(w.columns);
      b.columns += w.columns;
      d += w.dofs;
    }
  }
  // Constraint rows C (C dv = 0 on the piece) and impulse directions D (dv = V0 + Y_u D dz).
  const Eigen::MatrixXd dv = settings_.friction_model == FrictionModel::kSiconosFc3d
                                 ? Fc3dPieceSensitivity(groups, b, size, t1, h)
                                 : LcpPieceSensitivity(b, size);
  int d = 0;
  for (int g : groups) {
    const std::vector<int>& nodes = model_.groups[Idx(g)].nodes;
    for (size_t s = 0; s < nodes.size(); ++s) {
      const Eigen::Index o = d + 3 * static_cast<Eigen::Index>(s);
      Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(velocity_sensitivity_.data() + 9 * nodes[s]) =
          dv.block<3, 3>(o, o);
    }
    d += work_[Idx(g)].dofs;
  }
}

void MoreauJean::BuildColumns(int group, double t1) {
  GroupWork& w = work_[Idx(group)];
  const bool fc3d = settings_.friction_model == FrictionModel::kSiconosFc3d;
  int column = 0;
  // One column of G: the direction on the node's three rows, zero elsewhere.
  auto set = [&w](int col, Eigen::Index row, const Eigen::Vector3d& direction) {
    w.G.col(col).setZero();
    w.G.col(col).segment<3>(row) = direction;
  };
  for (size_t k = Idx(first_active_[Idx(group)]); k < active_.size() && active_[k].group == group; ++k) {
    ActiveContact& a = active_[k];
    const Contact& ct = model_.contacts[Idx(a.contact)];
    const Obstacle& ob = model_.obstacles[Idx(ct.obstacle)];
    const Eigen::Index o = 3 * model_.node_slot[Idx(ct.node)];
    a.normal_column = column;
    set(column++, o, ob.NormalAt(t1, data_));
    if (fc3d) {
      a.tangent_columns = 2;
      set(column++, o, ob.TangentAt(t1, data_));
      set(column++, o, ob.NormalAt(t1, data_).cross(ob.TangentAt(t1, data_)));
    } else if (ct.friction > 0.0) {
      a.tangent_columns = settings_.friction_facets;
      for (int j = 0; j < settings_.friction_facets; ++j) set(column++, o, FacetDirection(ob, t1, j));
    } else {
      a.tangent_columns = 0;
    }
  }
  w.columns = column;
  // Y = M̂⁻¹ G.
  w.Y.leftCols(column) = w.G.leftCols(column);
  SolveMHat(w, w.Y.leftCols(column));
}

void MoreauJean::SolveContacts(const std::vector<int>& groups, double t1, double h) {
  const bool fc3d = settings_.friction_model == FrictionModel::kSiconosFc3d;
  // Layout: every group's impulse columns first, then the sliding multipliers λ.
  int columns = 0;
  int contacts = 0;
  for (int g : groups) {
    work_[Idx(g)].column_offset = columns;
    columns += work_[Idx(g)].columns;
    for (size_t k = Idx(first_active_[Idx(g)]); k < active_.size() && active_[k].group == g; ++k) ++contacts;
  }
  int size = columns;
  for (int g : groups) {
    for (size_t k = Idx(first_active_[Idx(g)]); k < active_.size() && active_[k].group == g; ++k) {
      active_[k].lambda_row = (!fc3d && active_[k].tangent_columns > 0) ? size++ : -1;
    }
  }
  auto A = A_.topLeftCorner(size, size);
  auto b = b_.head(size);
  auto z = z_.head(size);
  A.setZero();
  b.setZero();
  int fc_index = 0;
  for (int g : groups) {
    GroupWork& w = work_[Idx(g)];
    const int off = w.column_offset;
    // Delassus block W = Gᵀ M̂⁻¹ G of the group (Eq. (5)); zero between groups.
    A.block(off, off, w.columns, w.columns).noalias() = w.G.leftCols(w.columns).transpose() * w.Y.leftCols(w.columns);
    for (size_t k = Idx(first_active_[Idx(g)]); k < active_.size() && active_[k].group == g; ++k) {
      const ActiveContact& a = active_[k];
      const Contact& ct = model_.contacts[Idx(a.contact)];
      const Obstacle& ob = model_.obstacles[Idx(ct.obstacle)];
      const Eigen::Vector3d x1 = q_.segment<3>(3 * ct.node) + h * v_.segment<3>(3 * ct.node);
      const Eigen::Vector3d plane_velocity = ob.VelocityAt(t1, x1, data_);
      const Eigen::Index o = 3 * model_.node_slot[Idx(ct.node)];
      const Eigen::Vector3d v_free = w.v_free.segment<3>(o);
      // Normal row: w = u_{k+1} + e u_k, relative to the plane (Eq. (2)).
      const int n_col = off + a.normal_column;
      b(n_col) = w.G.col(a.normal_column).segment<3>(o).dot(v_free - plane_velocity) + ct.restitution * a.u0;
      // Tangent rows: sliding velocity relative to the plane along each direction.
      for (int j = 1; j <= a.tangent_columns; ++j) {
        b(n_col + j) = w.G.col(a.normal_column + j).segment<3>(o).dot(v_free - plane_velocity);
        if (a.lambda_row >= 0) {
          A(n_col + j, a.lambda_row) = 1.0;
          A(a.lambda_row, n_col + j) = -1.0;
        }
      }
      if (a.lambda_row >= 0) A(a.lambda_row, n_col) = ct.friction;
      if (fc3d) mu_(fc_index++) = ct.friction;
    }
  }

  auto active_names = [&]() {
    std::string names;
    for (int g : groups) {
      for (size_t k = Idx(first_active_[Idx(g)]); k < active_.size() && active_[k].group == g; ++k) {
        names += (names.empty() ? "" : ", ") + model_.contacts[Idx(active_[k].contact)].name;
      }
    }
    return names;
  };
  int iterations = 0;
  if (fc3d) {
    const FrictionContactResult r =
        SolveFrictionContact(A, b, mu_.head(contacts), settings_.lcp.tolerance, settings_.lcp.max_iterations, z);
    iterations = r.iterations;
    if (!r.solved) {
      throw NumericalError("friction-contact problem of " + std::to_string(contacts) + " contact(s) [" +
                           active_names() + "] failed: " + r.message);
    }
  } else {
    const LcpResult r = lcp_.Solve(A, b, z);
    iterations = r.iterations;
    if (r.used_fallback) ++stats_.lcp_fallbacks;
    if (!r.solved) {
      throw NumericalError("LCP of " + std::to_string(contacts) + " active contact(s) [" + active_names() +
                           "] failed: " + r.message);
    }
  }
  ++stats_.lcp_solves;
  stats_.lcp_iterations += iterations;
  stats_.last_step_lcp_iterations += iterations;

  // v_{k+1} = v_free + M̂⁻¹ G z (Eq. (4)); record the impulses.
  for (int g : groups) {
    GroupWork& w = work_[Idx(g)];
    w.v_free.noalias() += w.Y.leftCols(w.columns) * z.segment(w.column_offset, w.columns);
    for (size_t k = Idx(first_active_[Idx(g)]); k < active_.size() && active_[k].group == g; ++k) {
      const ActiveContact& a = active_[k];
      const Eigen::Index o = 3 * model_.node_slot[Idx(model_.contacts[Idx(a.contact)].node)];
      impulse_(a.contact) = z(w.column_offset + a.normal_column);
      Eigen::Vector3d tangential = Eigen::Vector3d::Zero();
      for (int j = 1; j <= a.tangent_columns; ++j) {
        tangential += w.G.col(a.normal_column + j).segment<3>(o) * z(w.column_offset + a.normal_column + j);
      }
      friction_impulse_.col(a.contact) = tangential;
    }
  }
  if (sensitivities_on_) ContactSensitivity(groups, size, t1, h);
}

void MoreauJean::Step(double t, double h) {
  const double theta = settings_.theta;
  const double t1 = t + h;
  for (size_t g = 0; g < work_.size(); ++g) FreeVelocity(static_cast<int>(g), t, h);

  // Index set, group by group: contacts whose predicted gap closes within the step. u_k
  // (the normal velocity relative to the plane at the start of the step) is kept for
  // Newton's law.
  // A contact that acted in the last step (impulse_ still holds it) also stays while its free
  // motion would close it within this step, g + h u_free <= activation_gap: a node pressed onto
  // its plane (a blade resting on its stop through a stiff tie) creeps off it by round-off
  // (u_{k+1} = −e u_k alternates about 0), and once its gap passed activation_gap the standard
  // test dropped it from the LCP for a step, in which the pressing force drove it through the
  // plane (observed: 0.3 mm, then a spurious impact; the Puma scenes needed activation_gap 1e-6).
  // A contact that did not act, and one that opens (u_free > 0), is tested as before.
  active_.clear();
  stats_.last_step_lcp_iterations = 0;
  for (size_t g = 0; g < model_.groups.size(); ++g) {
    first_active_[g] = static_cast<int>(active_.size());
    for (int c : model_.groups[g].contacts) {
      const Contact& ct = model_.contacts[Idx(c)];
      const Obstacle& ob = model_.obstacles[Idx(ct.obstacle)];
      const Eigen::Vector3d x = q_.segment<3>(3 * ct.node);
      const Eigen::Vector3d n = ob.NormalAt(t, data_);
      const double bias = ob.GapRateBias(t, x, data_);
      const double u0 = n.dot(v_.segment<3>(3 * ct.node)) + bias;
      const double gap = ob.Gap(t, x, data_);
      bool active = gap + 0.5 * h * u0 <= settings_.activation_gap;
      if (!active && impulse_(c) > 0.0) {
        const double u_free = n.dot(work_[g].v_free.segment<3>(3 * model_.node_slot[Idx(ct.node)])) + bias;
        active = gap + h * u_free <= settings_.activation_gap;
      }
      if (active) active_.push_back(ActiveContact{c, static_cast<int>(g), 0, 0, -1, u0});
    }
    work_[g].columns = 0;
    if (active_.size() > static_cast<size_t>(first_active_[g])) BuildColumns(static_cast<int>(g), t1);
  }
  impulse_.setZero();  // (this step's, set by the contact problems)
  friction_impulse_.setZero();
  stats_.last_step_active = static_cast<int>(active_.size());
  stats_.activations += static_cast<long long>(active_.size());

  if (sensitivities_on_) {
    for (size_t g = 0; g < model_.groups.size(); ++g) {
      // Groups without an active contact (the others are made with their contact problem; in
      // one problem for all groups, every group is).
      if (work_[g].columns == 0 && (settings_.split_independent_lcps || active_.empty())) {
        FreeSensitivity(static_cast<int>(g), h);
      }
    }
  }
  if (!active_.empty()) {
    if (settings_.split_independent_lcps) {
      for (size_t g = 0; g < model_.groups.size(); ++g) {
        if (work_[g].columns == 0) continue;
        one_group_[0] = static_cast<int>(g);
        SolveContacts(one_group_, t1, h);
      }
    } else {
      SolveContacts(all_groups_, t1, h);
    }
  }
  stats_.max_step_lcp_iterations = std::max(stats_.max_step_lcp_iterations, stats_.last_step_lcp_iterations);

  // Eq. (3b), and scatter back to model order.
  for (size_t g = 0; g < model_.groups.size(); ++g) {
    const GroupWork& w = work_[g];
    const std::vector<int>& nodes = model_.groups[g].nodes;
    for (size_t s = 0; s < nodes.size(); ++s) {
      const Eigen::Index o = 3 * static_cast<Eigen::Index>(s);
      const int i = nodes[s];
      q_.segment<3>(3 * i) += h * (theta * w.v_free.segment<3>(o) + (1.0 - theta) * v_.segment<3>(3 * i));
      v_.segment<3>(3 * i) = w.v_free.segment<3>(o);
      applied_.segment<3>(3 * i) = external_.segment<3>(3 * i);
      if (w.coupled) {  // the held force at the end position (see the header)
        applied_.segment<3>(3 * i) +=
            Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(stiffness_.data() + 9 * i) *
            (q_.segment<3>(3 * i) - reference_.segment<3>(3 * i));
      }
    }
  }
  time_ = t1;
}

}  // namespace cosim::nonsmooth
