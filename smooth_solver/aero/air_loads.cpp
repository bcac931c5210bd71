#include "smooth_solver/aero/air_loads.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numbers>

#include "interface/base/errors.h"
#include "smooth_solver/constraints/bilinear_constraints.h"
#include "smooth_solver/elastic/hex27.h"

namespace cosim::smooth {

namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

Matrix3d Skew(const Vector3d& a) {
  Matrix3d m;
  m << 0.0, -a.z(), a.y(), a.z(), 0.0, -a.x(), -a.y(), a.x(), 0.0;
  return m;
}

// Gauss–Legendre points and weights on [−1, 1], n = 1..6.
void GaussLegendre(int n, std::vector<double>* x, std::vector<double>* w) {
  static const double x1[] = {0.0}, w1[] = {2.0};
  static const double x2[] = {-0.5773502691896257, 0.5773502691896257}, w2[] = {1.0, 1.0};
  static const double x3[] = {-0.7745966692414834, 0.0, 0.7745966692414834},
                      w3[] = {0.5555555555555556, 0.8888888888888888, 0.5555555555555556};
  static const double x4[] = {-0.8611363115940526, -0.3399810435848563, 0.3399810435848563, 0.8611363115940526},
                      w4[] = {0.3478548451374538, 0.6521451548625461, 0.6521451548625461, 0.3478548451374538};
  static const double x5[] = {-0.9061798459386640, -0.5384693101056831, 0.0, 0.5384693101056831, 0.9061798459386640},
                      w5[] = {0.2369268850561891, 0.4786286704993665, 0.5688888888888889, 0.4786286704993665,
                              0.2369268850561891};
  static const double x6[] = {-0.9324695142031521, -0.6612093864662645, -0.2386191860831969,
                              0.2386191860831969,  0.6612093864662645,  0.9324695142031521},
                      w6[] = {0.1713244923791704, 0.3607615730481386, 0.4679139345726910,
                              0.4679139345726910, 0.3607615730481386, 0.1713244923791704};
  const double* xs[] = {x1, x2, x3, x4, x5, x6};
  const double* ws[] = {w1, w2, w3, w4, w5, w6};
  x->assign(xs[n - 1], xs[n - 1] + n);
  w->assign(ws[n - 1], ws[n - 1] + n);
}

// Smoothstep from 0 (x <= 0) to 1 (x >= 1).
double Smoothstep(double x) {
  if (x <= 0.0) return 0.0;
  if (x >= 1.0) return 1.0;
  return x * x * (3.0 - 2.0 * x);
}

}  // namespace

double Airwake::Ratio(double xi) const {
  switch (form) {
    case Form::kUniform:
      return windward;
    case Form::kLinear: {
      // windward at ξ = −L, leeward at +L, held beyond.
      const double s = std::clamp(0.5 * (xi / length + 1.0), 0.0, 1.0);
      return windward + s * (leeward - windward);
    }
    case Form::kStep: {
      // A half cosine over the blend: windward before edge − w/2, leeward after edge + w/2.
      const double s = std::clamp((xi - edge) / edge_width + 0.5, 0.0, 1.0);
      return windward + 0.5 * (1.0 - std::cos(std::numbers::pi * s)) * (leeward - windward);
    }
    case Form::kNone:
    case Form::kTable:
      break;
  }
  return 0.0;
}

Vector3d Airwake::Velocity(const Vector3d& x, double t) const {
  if (form == Form::kNone) return Vector3d::Zero();
  const double v = growth.Value(t) * speed;
  const Vector3d r = x - origin;
  if (form != Form::kTable) return v * (along + Ratio(along.dot(r)) * up);
  // Bilinear in the cell holding (x_s, y_s), the point held onto the grid's edges.
  auto cell = [](const std::vector<double>& knots, double at, size_t* i, double* s) {
    if (knots.size() == 1 || at <= knots.front()) {
      *i = 0;
      *s = 0.0;
    } else if (at >= knots.back()) {
      *i = knots.size() - 2;
      *s = 1.0;
    } else {
      *i = static_cast<size_t>(std::upper_bound(knots.begin(), knots.end(), at) - knots.begin()) - 1;
      *s = (at - knots[*i]) / (knots[*i + 1] - knots[*i]);
    }
  };
  size_t i = 0, j = 0;
  double sx = 0.0, sy = 0.0;
  cell(xs, bow.dot(r), &i, &sx);
  cell(ys, port.dot(r), &j, &sy);
  const size_t ny = ys.size(), i1 = std::min(i + 1, xs.size() - 1), j1 = std::min(j + 1, ny - 1);
  const Vector3d ship = (1 - sx) * ((1 - sy) * grid[i * ny + j] + sy * grid[i * ny + j1]) +
                        sx * ((1 - sy) * grid[i1 * ny + j] + sy * grid[i1 * ny + j1]);
  return v * (ship.x() * bow + ship.y() * port + ship.z() * up);
}

Vector3d AirModel::Velocity(const Vector3d& x, double t) const {
  Vector3d u(wind[0].Value(t), wind[1].Value(t), wind[2].Value(t));
  u += airwake.Velocity(x, t);
  for (const GustFront& g : gusts) {
    const double d = g.front_speed * t - g.front_direction.dot(x - g.origin);
    u += g.profile.Value(d) * g.direction;
  }
  return u;
}

// Everything one section's loads need, with the derivatives of (f1, f2, f3, m) with respect to
// the section-frame relative velocity (v1, v2, v3).
struct AirLoads::Local {
  Vector3d a, pdot, e1, e2, e3, v;
  double v1 = 0, v2 = 0, v3 = 0, alpha = 0, mach = 0;
  Vector3d f = Vector3d::Zero();  // f1, f2, f3 per span
  double m = 0.0;
  Eigen::Matrix<double, 4, 3> D = Eigen::Matrix<double, 4, 3>::Zero();
  Vector3d F = Vector3d::Zero();  // global force per span
};

bool LocateInMesh(const ElasticMesh& mesh, const Vector3d& X, MeshPoint* at) {
  for (size_t e = 0; e < mesh.elements.size(); ++e) {
    const auto& nodes = mesh.elements[e];
    Eigen::Matrix<double, 3, 27> P;
    for (int a = 0; a < 27; ++a) P.col(a) = mesh.nodes.col(nodes[static_cast<size_t>(a)]);
    const Vector3d lo = P.rowwise().minCoeff(), hi = P.rowwise().maxCoeff();
    const double pad = 1e-9 * (1.0 + (hi - lo).norm());
    if ((X.array() < lo.array() - pad).any() || (X.array() > hi.array() + pad).any()) continue;
    // Newton on the isoparametric map X(ξ) = Σ N_a(ξ) X_a from the element's centre.
    Vector3d xi = Vector3d::Zero();
    std::array<double, 27> N{};
    std::array<Vector3d, 27> dN{};
    Matrix3d J = Matrix3d::Identity();
    for (int it = 0; it < 30; ++it) {
      const auto s0 = Hex27::Shape1D(xi(0)), s1 = Hex27::Shape1D(xi(1)), s2 = Hex27::Shape1D(xi(2));
      const auto d0 = Hex27::Shape1DDerivative(xi(0)), d1 = Hex27::Shape1DDerivative(xi(1)),
                 d2 = Hex27::Shape1DDerivative(xi(2));
      Vector3d x = Vector3d::Zero();
      J.setZero();
      for (int k = 0; k < 3; ++k) {
        for (int j = 0; j < 3; ++j) {
          for (int i = 0; i < 3; ++i) {
            const size_t a = static_cast<size_t>(i + 3 * j + 9 * k);
            N[a] = s0[static_cast<size_t>(i)] * s1[static_cast<size_t>(j)] * s2[static_cast<size_t>(k)];
            dN[a] = Vector3d(d0[static_cast<size_t>(i)] * s1[static_cast<size_t>(j)] * s2[static_cast<size_t>(k)],
                             s0[static_cast<size_t>(i)] * d1[static_cast<size_t>(j)] * s2[static_cast<size_t>(k)],
                             s0[static_cast<size_t>(i)] * s1[static_cast<size_t>(j)] * d2[static_cast<size_t>(k)]);
            x += N[a] * P.col(static_cast<int>(a));
            J += P.col(static_cast<int>(a)) * dN[a].transpose();
          }
        }
      }
      const Vector3d step = J.partialPivLu().solve(X - x);
      xi += step;
      if (step.norm() < 1e-13) break;
      if (xi.cwiseAbs().maxCoeff() > 3.0) break;  // far outside: not this element
    }
    if (xi.cwiseAbs().maxCoeff() > 1.0 + 1e-9) continue;
    at->element = static_cast<int>(e);
    at->N = N;
    const Matrix3d Jinv_t = J.inverse().transpose();
    for (size_t a = 0; a < 27; ++a) at->grad[a] = Jinv_t * dN[a];
    return true;
  }
  return false;
}

AirLoads::AirLoads(AeroModel model, std::vector<int> elastic_offset)
    : model_(std::move(model)), elastic_offset_(std::move(elastic_offset)) {
  rotor_sections_.resize(model_.rotors.size());
  std::vector<double> gx, gw;
  for (size_t si = 0; si < model_.surfaces.size(); ++si) {
    const AeroSurfaceSpec& sf = model_.surfaces[si];
    GaussLegendre(sf.gauss_points, &gx, &gw);
    const double sa = sf.stations.front().s, sb = sf.stations.back().s;
    // Integration intervals: a beam's elements (clipped to the loaded span), or equal segments.
    std::vector<std::pair<double, double>> intervals;
    if (sf.on_beam) {
      for (const BeamElement& e : sf.beam.elements) {
        const double lo = std::max(e.s0, sa), hi = std::min(e.s0 + e.length, sb);
        if (hi > lo) intervals.emplace_back(lo, hi);
      }
    } else {
      for (int k = 0; k < sf.segments; ++k) {
        intervals.emplace_back(sa + (sb - sa) * k / sf.segments, sa + (sb - sa) * (k + 1) / sf.segments);
      }
    }
    for (const auto& [lo, hi] : intervals) {
      for (size_t g = 0; g < gx.size(); ++g) {
        const double s = 0.5 * (lo + hi) + 0.5 * (hi - lo) * gx[g];
        sections_.push_back(Section(static_cast<int>(si), s, 0.5 * (hi - lo) * gw[g]));
        if (sf.rotor >= 0)
          rotor_sections_[static_cast<size_t>(sf.rotor)].push_back(static_cast<int>(sections_.size() - 1));
      }
    }
  }
  for (size_t k = 0; k < sections_.size(); ++k) {
    const AeroSection& s = sections_[k];
    const AeroSection* previous = groups_.empty() ? nullptr : &sections_[static_cast<size_t>(groups_.back().first)];
    const bool same = previous != nullptr && previous->slots == s.slots &&
                      std::equal(s.slot.begin(), s.slot.begin() + s.slots, previous->slot.begin());
    if (!same) {
      Group g;
      g.first = static_cast<int>(k);
      g.mask.assign(static_cast<size_t>(s.slots * s.slots), 0);
      groups_.push_back(std::move(g));
    }
    Group& g = groups_.back();
    g.last = static_cast<int>(k + 1);
    for (int i = 0; i < s.slots; ++i) {
      const size_t ii = static_cast<size_t>(i);
      if (s.wa[ii] == 0.0 && s.we[ii] == 0.0) continue;
      for (int j = 0; j < s.slots; ++j) {
        const size_t jj = static_cast<size_t>(j);
        if (s.wp[jj] != 0.0 || s.we[jj] != 0.0 || s.wn[jj] != 0.0) g.mask[static_cast<size_t>(i * s.slots + j)] = 1;
      }
    }
  }
}

namespace {

// Adds the weights of one coordinate slot to a section (summed with the slot's if it has it).
void AddSlot(AeroSection* sec, int slot, double wa, double we, double wn) {
  for (int k = 0; k < sec->slots; ++k) {
    if (sec->slot[static_cast<size_t>(k)] == slot) {
      sec->wa[static_cast<size_t>(k)] += wa;
      sec->we[static_cast<size_t>(k)] += we;
      sec->wn[static_cast<size_t>(k)] += wn;
      return;
    }
  }
  const size_t k = static_cast<size_t>(sec->slots++);
  sec->slot[k] = slot;
  sec->wa[k] = wa;
  sec->we[k] = we;
  sec->wn[k] = wn;
}

// A beam section's weights: the element containing s, its shape functions there, and the chord and
// normal from the interpolated directors turned by the table's structural twist and the aerodynamic
// twist (cos, sin: ct, stw); x_qc: the reference line's offset to the quarter chord.
void BeamSectionWeights(const AeroSurfaceSpec& sf, double s, double ct, double stw, double x_qc, AeroSection* sec) {
  auto add = [&](int slot, double wa, double we, double wn) { AddSlot(sec, slot, wa, we, wn); };
  // The element containing s and the shape functions there.
  const BeamModel& beam = sf.beam;
  const int nn = beam.nodes_per_element;
  const BeamElement* el = &beam.elements.back();
  for (const BeamElement& e : beam.elements) {
    if (s <= e.s0 + e.length) {
      el = &e;
      break;
    }
  }
  const double xi = std::min(std::max(2.0 * (s - el->s0) / el->length - 1.0, -1.0), 1.0);
  double N[3], dN[3];
  BeamShape(nn, xi, N, dN);
  // Reference directors interpolated at s, and the structural twist the table gives there: the
  // section's chord c = cos δ d2 + sin δ d3 with δ the difference (the interpolated directors
  // carry the nodes' twist only).
  Vector3d d2r = Vector3d::Zero(), d3r = Vector3d::Zero();
  for (int I = 0; I < nn; ++I) {
    d2r += N[I] * el->q_ref.segment<3>(kCoordinatesPerBody * I + 6);
    d3r += N[I] * el->q_ref.segment<3>(kCoordinatesPerBody * I + 9);
  }
  const double theta = beam.table.At(s).twist;
  const Vector3d chord_structural = std::cos(theta) * beam.d2_0 + std::sin(theta) * beam.d3_0;
  const double delta = std::atan2(chord_structural.dot(d3r.normalized()), chord_structural.dot(d2r.normalized()));
  const double cd = std::cos(delta), sd = std::sin(delta), us = sf.upper_sign;
  // c = cd d2 + sd d3; n = us (−sd d2 + cd d3).
  const double e_d2 = ct * cd + stw * us * (-sd), e_d3 = ct * sd + stw * us * cd;
  const double n_d2 = -stw * cd + ct * us * (-sd), n_d3 = -stw * sd + ct * us * cd;
  for (int I = 0; I < nn; ++I) {
    const int base = kCoordinatesPerBody * el->node[static_cast<size_t>(I)];
    add(base, N[I], 0.0, 0.0);
    add(base + 6, x_qc * N[I] * e_d2, N[I] * e_d2, N[I] * n_d2);
    add(base + 9, x_qc * N[I] * e_d3, N[I] * e_d3, N[I] * n_d3);
  }
}

}  // namespace

AeroSection AirLoads::Section(int surface, double s, double weight) const {
  const AeroSurfaceSpec& sf = model_.surfaces[static_cast<size_t>(surface)];
  AeroSection sec;
  sec.s = s;
  sec.weight = weight;
  sec.rotor = sf.rotor;
  // Station data linear in s (the outboard side at a step).
  const auto& st = sf.stations;
  size_t i = 0;
  while (i + 2 < st.size() && s >= st[i + 1].s) ++i;
  const double span = st[i + 1].s - st[i].s;
  const double w = span > 0.0 ? std::min(std::max((s - st[i].s) / span, 0.0), 1.0) : 1.0;
  auto mix = [&](double a, double b) { return a + w * (b - a); };
  sec.chord = mix(st[i].chord, st[i + 1].chord);
  const double twist = mix(st[i].twist, st[i + 1].twist);
  const double x_qc = mix(st[i].quarter_chord, st[i + 1].quarter_chord);
  sec.airfoil = {model_.airfoils[static_cast<size_t>(st[i].airfoil)].get(),
                 model_.airfoils[static_cast<size_t>(st[i + 1].airfoil)].get()};
  sec.blend = st[i].airfoil == st[i + 1].airfoil ? 0.0 : w;
  const double cd0_a = sec.airfoil[0]->Evaluate(0.0, 0.0).cd, cd0_b = sec.airfoil[1]->Evaluate(0.0, 0.0).cd;
  sec.cd0 = cd0_a + sec.blend * (cd0_b - cd0_a);
  // Chord axis and normal as combinations of two section vectors (c_ref, n_ref), rotated by the
  // aerodynamic twist: e1 = cos τ c + sin τ n, e2 = −sin τ c + cos τ n.
  const double ct = std::cos(twist), stw = std::sin(twist);
  auto add = [&](int slot, double wa, double we, double wn) { AddSlot(&sec, slot, wa, we, wn); };
  if (sf.on_beam) {
    BeamSectionWeights(sf, s, ct, stw, x_qc, &sec);
  } else if (sf.elastic >= 0) {
    // The material point of the reference line and the reference chord and normal, carried by
    // the deformation gradient: e1 = F c = Σ_a x_a (∇N_a · c), e2 = F n.
    const Vector3d c = sf.chord_b, n = sf.upper_sign * sf.axis_b.cross(sf.chord_b);
    const Vector3d c1 = ct * c + stw * n, n1 = -stw * c + ct * n;
    MeshPoint at;
    const bool inside = LocateInMesh(sf.mesh, sf.root_b + s * sf.axis_b, &at);
    COSIM_ASSERT(inside, "an aero section outside its elastic body (AddAero checks the stations)");
    const int offset = elastic_offset_[static_cast<size_t>(sf.elastic)];
    const auto& nodes = sf.mesh.elements[static_cast<size_t>(at.element)];
    for (size_t a = 0; a < 27; ++a) {
      const double we = at.grad[a].dot(c1), wn = at.grad[a].dot(n1);
      add(offset + 3 * nodes[a], at.N[a] + x_qc * we, we, wn);
    }
  } else {
    const Vector3d point = sf.root_b + s * sf.axis_b;
    const Vector3d c = sf.chord_b, n = sf.upper_sign * sf.axis_b.cross(sf.chord_b);
    const Vector3d e1 = ct * c + stw * n, e2 = -stw * c + ct * n;
    const Vector3d a = point + x_qc * e1;
    const int base = kCoordinatesPerBody * sf.body;
    add(base, 1.0, 0.0, 0.0);
    for (int k = 0; k < 3; ++k) add(base + 3 * (k + 1), a(k), e1(k), e2(k));
  }
  // p = a − (c/2) e1.
  for (int k = 0; k < sec.slots; ++k) {
    const size_t j = static_cast<size_t>(k);
    sec.wp[j] = sec.wa[j] - 0.5 * sec.chord * sec.we[j];
  }
  return sec;
}

void AirLoads::Compute(const AeroSection& s, const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t,
                       const RotorState* rotor, bool derivatives, Local* o) const {
  o->a.setZero();
  o->pdot.setZero();
  o->e1.setZero();
  o->e2.setZero();
  for (int k = 0; k < s.slots; ++k) {
    const size_t j = static_cast<size_t>(k);
    const auto qk = q.segment<3>(s.slot[j]);
    o->a += s.wa[j] * qk;
    o->e1 += s.we[j] * qk;
    o->e2 += s.wn[j] * qk;
    o->pdot += s.wp[j] * qdot.segment<3>(s.slot[j]);
  }
  o->e3 = o->e1.cross(o->e2);
  Vector3d u = model_.air.Velocity(o->a, t);
  if (rotor != nullptr && rotor->started) {
    const Vector3d r = o->a - rotor->centre;
    const double R = model_.rotors[static_cast<size_t>(s.rotor)].radius;
    const double nu = rotor->nu(0) + (rotor->nu(1) * r.dot(rotor->x) + rotor->nu(2) * r.dot(rotor->y)) / R;
    u -= nu * rotor->n;
  }
  o->v = o->pdot - u;
  const double v1 = o->e1.dot(o->v), v2 = o->e2.dot(o->v), v3 = o->e3.dot(o->v);
  o->v1 = v1;
  o->v2 = v2;
  o->v3 = v3;
  const AirModel& air = model_.air;
  const double vp2 = v1 * v1 + v2 * v2, vp = std::sqrt(vp2);
  const double eps = air.guard_speed, vr = std::sqrt(vp2 + eps * eps);
  o->alpha = std::atan2(-v2, v1);
  o->mach = vp / air.speed_of_sound;
  PolarValue p = s.airfoil[0]->Evaluate(o->alpha, o->mach);
  if (s.blend > 0.0) {
    const PolarValue b = s.airfoil[1]->Evaluate(o->alpha, o->mach);
    const double w = s.blend;
    p.cl += w * (b.cl - p.cl);
    p.cd += w * (b.cd - p.cd);
    p.cm += w * (b.cm - p.cm);
    p.cl_alpha += w * (b.cl_alpha - p.cl_alpha);
    p.cd_alpha += w * (b.cd_alpha - p.cd_alpha);
    p.cm_alpha += w * (b.cm_alpha - p.cm_alpha);
    p.cl_mach += w * (b.cl_mach - p.cl_mach);
    p.cd_mach += w * (b.cd_mach - p.cd_mach);
    p.cm_mach += w * (b.cm_mach - p.cm_mach);
  }
  const double Q = 0.5 * air.density * s.chord, c = s.chord;
  const double phi = Q * vp2 / vr;
  const double cl = p.cl, cd = p.cd, cm = p.cm, cd0 = s.cd0;
  o->f = Vector3d(-phi * (cl * v2 + cd * v1), phi * (cl * v1 - cd * v2), -phi * cd0 * v3);
  o->m = Q * vp2 * c * cm;
  o->F = o->f(0) * o->e1 + o->f(1) * o->e2 + o->f(2) * o->e3;
  if (!derivatives) return;
  // ∂φ/∂v_i, and φ ∂α/∂v_i, φ ∂M/∂v_i with the 1/v_p² and 1/v_p cancelled (finite at rest).
  const double vi[2] = {v1, v2};
  const double dphi[2] = {Q * v1 * (2.0 / vr - vp2 / (vr * vr * vr)), Q * v2 * (2.0 / vr - vp2 / (vr * vr * vr))};
  const double phi_a[2] = {Q * v2 / vr, -Q * v1 / vr};
  double phi_m[2] = {0.0, 0.0}, psi_m[2] = {0.0, 0.0};
  if (vp > 0.0) {
    for (int i = 0; i < 2; ++i) {
      phi_m[i] = Q * vp * vi[i] / (vr * air.speed_of_sound);
      psi_m[i] = Q * vp * vi[i] / air.speed_of_sound;
    }
  }
  for (int i = 0; i < 2; ++i) {
    const double pcl = p.cl_alpha * phi_a[i] + p.cl_mach * phi_m[i];
    const double pcd = p.cd_alpha * phi_a[i] + p.cd_mach * phi_m[i];
    const double dv1 = i == 0 ? 1.0 : 0.0, dv2 = i == 1 ? 1.0 : 0.0;
    o->D(0, i) = -dphi[i] * (cl * v2 + cd * v1) - (pcl * v2 + pcd * v1) - phi * (cl * dv2 + cd * dv1);
    o->D(1, i) = dphi[i] * (cl * v1 - cd * v2) + (pcl * v1 - pcd * v2) + phi * (cl * dv1 - cd * dv2);
    o->D(2, i) = -dphi[i] * cd0 * v3;
    // m = c ψ C_m with ψ = Q v_p²: ∂ψ/∂v_i = 2 Q v_i, ψ ∂α/∂v_i = Q (v2, −v1)_i.
    const double psi_a = i == 0 ? Q * v2 : -Q * v1;
    o->D(3, i) = c * (2.0 * Q * vi[i] * cm + p.cm_alpha * psi_a + p.cm_mach * psi_m[i]);
  }
  o->D(0, 2) = 0.0;
  o->D(1, 2) = 0.0;
  o->D(2, 2) = -phi * cd0;
  o->D(3, 2) = 0.0;
}

void AirLoads::AddForce(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, const SystemData& data,
                        Eigen::Ref<Eigen::VectorXd> f) const {
  Local o;
  for (const AeroSection& s : sections_) {
    const RotorState* r = s.rotor >= 0 ? &data.rotors[static_cast<size_t>(s.rotor)] : nullptr;
    Compute(s, q, qdot, t, r, false, &o);
    const Vector3d F = s.weight * o.F, couple = s.weight * o.m * o.e2;
    for (int k = 0; k < s.slots; ++k) {
      const size_t j = static_cast<size_t>(k);
      f.segment<3>(s.slot[j]) += s.wa[j] * F + s.we[j] * couple;
    }
  }
}

void AirLoads::AddTangent(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, const SystemData& data,
                          double stiffness_scale, double damping_scale, SparseSink* sink) const {
  constexpr int kMax = 3 * AeroSection::kMaxSlots;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kMax, kMax> L;
  Local o;
  for (const Group& group : groups_) {
    const int slots = sections_[static_cast<size_t>(group.first)].slots;
    L.setZero(3 * slots, 3 * slots);
    for (int k = group.first; k < group.last; ++k) {
      const AeroSection& s = sections_[static_cast<size_t>(k)];
      const RotorState* r = s.rotor >= 0 ? &data.rotors[static_cast<size_t>(s.rotor)] : nullptr;
      Compute(s, q, qdot, t, r, true, &o);
      Matrix3d R;
      R << o.e1, o.e2, o.e3;
      const Eigen::Matrix3d DF = o.D.topRows<3>();
      const Eigen::RowVector3d Dm = o.D.row(3);
      // ∂v_local/∂e1 and ∂v_local/∂e2 (rows v1, v2, v3).
      Matrix3d SE, SN;
      SE.row(0) = o.v.transpose();
      SE.row(1).setZero();
      SE.row(2) = o.e2.cross(o.v).transpose();
      SN.row(0).setZero();
      SN.row(1) = o.v.transpose();
      SN.row(2) = o.v.cross(o.e1).transpose();
      const double w = s.weight;
      // Scaled by −w and by the integrator's factors: B_ij = ks K_ij + ds C_ij.
      const Matrix3d G = -w * damping_scale * (R * DF * R.transpose());        // ∂F/∂ṗ
      const Matrix3d Gm = -w * damping_scale * (o.e2 * (Dm * R.transpose()));  // ∂(m e2)/∂ṗ
      const Matrix3d KE =
          -w * stiffness_scale * (R * DF * SE + o.f(0) * Matrix3d::Identity() - o.f(2) * Skew(o.e2));  // ∂F/∂e1
      const Matrix3d KN =
          -w * stiffness_scale * (R * DF * SN + o.f(1) * Matrix3d::Identity() + o.f(2) * Skew(o.e1));  // ∂F/∂e2
      const Matrix3d ME = -w * stiffness_scale * (o.e2 * (Dm * SE));                               // ∂(m e2)/∂e1
      const Matrix3d MN = -w * stiffness_scale * (o.e2 * (Dm * SN) + o.m * Matrix3d::Identity());  // ∂(m e2)/∂e2
      for (int i = 0; i < slots; ++i) {
        const size_t ii = static_cast<size_t>(i);
        const double wa = s.wa[ii], we = s.we[ii];
        if (wa == 0.0 && we == 0.0) continue;
        const Matrix3d rowC = wa * G + we * Gm;
        for (int j = 0; j < slots; ++j) {
          const size_t jj = static_cast<size_t>(j);
          if (s.wp[jj] == 0.0 && s.we[jj] == 0.0 && s.wn[jj] == 0.0) continue;
          L.block<3, 3>(3 * i, 3 * j) +=
              s.wp[jj] * rowC + wa * (s.we[jj] * KE + s.wn[jj] * KN) + we * (s.we[jj] * ME + s.wn[jj] * MN);
        }
      }
    }
    const AeroSection& s = sections_[static_cast<size_t>(group.first)];
    for (int i = 0; i < slots; ++i) {
      for (int j = 0; j < slots; ++j) {
        if (group.mask[static_cast<size_t>(i * slots + j)] == 0) continue;
        sink->AddBlock3(s.slot[static_cast<size_t>(i)], s.slot[static_cast<size_t>(j)], L.block<3, 3>(3 * i, 3 * j));
      }
    }
  }
}

void AirLoads::Pattern(SparseSink* sink) const {
  for (const Group& group : groups_) {
    const AeroSection& s = sections_[static_cast<size_t>(group.first)];
    for (int i = 0; i < s.slots; ++i) {
      for (int j = 0; j < s.slots; ++j) {
        if (group.mask[static_cast<size_t>(i * s.slots + j)] == 0) continue;
        for (int a = 0; a < 3; ++a) {
          for (int b = 0; b < 3; ++b)
            sink->Add(s.slot[static_cast<size_t>(i)] + a, s.slot[static_cast<size_t>(j)] + b, 0.0);
        }
      }
    }
  }
}

AirLoads::SectionResult AirLoads::Evaluate(const AeroSection& section, const Eigen::VectorXd& q,
                                           const Eigen::VectorXd& qdot, double t, const SystemData& data) const {
  Local o;
  const RotorState* r = section.rotor >= 0 ? &data.rotors[static_cast<size_t>(section.rotor)] : nullptr;
  Compute(section, q, qdot, t, r, false, &o);
  SectionResult res;
  res.alpha = o.alpha;
  res.mach = o.mach;
  res.moment = o.m;
  res.force_local = o.f;
  res.force = o.F;
  res.point = o.a;
  return res;
}

void AirLoads::UpdateFrame(int r, const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t,
                           RotorState* s) const {
  const RotorSpec& rs = model_.rotors[static_cast<size_t>(r)];
  const int o = kCoordinatesPerBody * rs.hub;
  s->centre = q.segment<3>(o);
  Vector3d n = Vector3d::Zero(), omega = Vector3d::Zero();
  for (int k = 0; k < 3; ++k) {
    n += rs.axis_b(k) * q.segment<3>(o + 3 * (k + 1));
    omega += 0.5 * q.segment<3>(o + 3 * (k + 1)).cross(qdot.segment<3>(o + 3 * (k + 1)));
  }
  s->n = n.normalized();
  // A non-rotating in-plane frame: global x (or y) projected on the disk.
  Vector3d ref = Vector3d::UnitX() - s->n.x() * s->n;
  if (ref.norm() < 0.1) ref = Vector3d::UnitY() - s->n.y() * s->n;
  s->x = ref.normalized();
  s->y = s->n.cross(s->x);
  s->tip_speed = std::abs(omega.dot(s->n)) * rs.radius;
  s->fade = Smoothstep(2.0 * s->tip_speed / rs.guard_tip_speed - 1.0);
  // Free stream relative to the hub.
  const Vector3d u = model_.air.Velocity(s->centre, t) - qdot.segment<3>(o);
  s->v_normal = -u.dot(s->n);
  const Vector3d in_plane = u + s->v_normal * s->n;
  s->v_parallel = in_plane.norm();
  s->downstream = s->v_parallel > 1e-9 ? Vector3d(in_plane / s->v_parallel) : s->x;
}

AirLoads::RotorResult AirLoads::RotorLoads(int r, const RotorState& state, const Eigen::VectorXd& q,
                                           const Eigen::VectorXd& qdot, double t) const {
  RotorResult res;
  Local o;
  for (int k : rotor_sections_[static_cast<size_t>(r)]) {
    const AeroSection& s = sections_[static_cast<size_t>(k)];
    Compute(s, q, qdot, t, &state, false, &o);
    const Vector3d F = s.weight * o.F;
    const Vector3d arm = o.a - state.centre;
    const double fn = F.dot(state.n);
    res.thrust += fn;
    res.torque += arm.cross(F).dot(state.n) + s.weight * o.m * o.e3.dot(state.n);
    res.moment_x += fn * arm.dot(state.x);
    res.moment_y += fn * arm.dot(state.y);
  }
  res.induced = state.nu(0);
  res.tip_speed = state.tip_speed;
  res.inflow_ratio = state.tip_speed > 0.0 ? (state.v_normal + state.nu(0)) / state.tip_speed : 0.0;
  return res;
}

AirLoads::RotorResult AirLoads::Rotor(int r, const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t,
                                      const SystemData& data) const {
  return RotorLoads(r, data.rotors[static_cast<size_t>(r)], q, qdot, t);
}

void AirLoads::AcceptStep(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, SystemData* data) const {
  const double rho = model_.air.density;
  for (size_t r = 0; r < model_.rotors.size(); ++r) {
    const RotorSpec& rs = model_.rotors[r];
    RotorState& st = data->rotors[r];
    const double h = st.started ? t - st.t : 0.0;
    UpdateFrame(static_cast<int>(r), q, qdot, t, &st);
    st.started = true;
    st.t = t;
    if (rs.inflow == RotorSpec::Inflow::kNone) {
      st.nu.setZero();
      continue;
    }
    const double area = std::numbers::pi * rs.radius * rs.radius;
    if (rs.inflow == RotorSpec::Inflow::kUniform || h <= 0.0) {
      // Glauert momentum, solved at this state: 2 ρ A V_T(ν_m) ν_m = fade · T(κ ν_m), secant on
      // ν_m; the blades see ν = κ ν_m (κ the induced-power factor, 1 by default).
      const double kappa = rs.induced_velocity_factor;
      RotorState trial = st;
      trial.nu(1) = trial.nu(2) = 0.0;
      auto residual = [&](double nu) {
        trial.nu(0) = kappa * nu;
        const double T = RotorLoads(static_cast<int>(r), trial, q, qdot, t).thrust;
        const double vt = std::hypot(st.v_parallel, st.v_normal + nu);
        return 2.0 * rho * area * vt * nu - st.fade * rs.load_factor * T;
      };
      double x0 = st.nu(0) / kappa, f0 = residual(x0);
      double x1 = x0 + 1e-3 * (1.0 + std::abs(x0)), f1 = residual(x1);
      for (int it = 0; it < 30 && std::abs(x1 - x0) > 1e-10 * (1.0 + std::abs(x1)); ++it) {
        if (f1 == f0) break;
        const double x2 = x1 - f1 * (x1 - x0) / (f1 - f0);
        x0 = x1;
        f0 = f1;
        x1 = x2;
        f1 = residual(x1);
      }
      st.nu = Vector3d(kappa * x1, 0.0, 0.0);
      continue;
    }
    // Pitt–Peters (docs/reference/aero.md), in dimensional form (ν = λ ΩR, forcing T/(ρA) and the
    // thrust's first moments /(ρAR)): L M R ν̇ + ν = L F with L = L̃(χ) diag(1/V_T, 1/V, 1/V),
    // one implicit Euler step from the last accepted state with F and L at this state.
    const RotorResult loads = RotorLoads(static_cast<int>(r), st, q, qdot, t);
    const Vector3d F = st.fade * rs.load_factor / (rho * area) *
                       Vector3d(loads.thrust, loads.moment_x / rs.radius, loads.moment_y / rs.radius);
    const double vn = st.v_normal + st.nu(0);
    const double vt = std::max(std::hypot(st.v_parallel, vn), 1e-3);
    const double vm = std::max((st.v_parallel * st.v_parallel + vn * (vn + st.nu(0))) / vt, 1e-3);
    // Wake skew χ from the shaft, capped at 75° (L̃ stops being positive definite at 77.7°).
    const double chi = std::min(std::atan2(st.v_parallel, std::max(vn, 0.0)), 75.0 * std::numbers::pi / 180.0);
    const double k = 15.0 * std::numbers::pi / 64.0 * std::tan(0.5 * chi), cc = std::cos(chi);
    Matrix3d Lw;  // (ν0, downstream, lateral)
    Lw << 0.5, k, 0.0, k, 4.0 * cc / (1.0 + cc), 0.0, 0.0, 0.0, 4.0 / (1.0 + cc);
    Matrix3d P = Matrix3d::Identity();  // wind frame → (ν0, x, y)
    const double dx = st.downstream.dot(st.x), dy = st.downstream.dot(st.y);
    P(1, 1) = dx;
    P(1, 2) = -dy;
    P(2, 1) = dy;
    P(2, 2) = dx;
    const Matrix3d L = P * Lw * P.transpose() * Vector3d(1.0 / vt, 1.0 / vm, 1.0 / vm).asDiagonal();
    const double m0 = 128.0 / (75.0 * std::numbers::pi), m1 = 16.0 / (45.0 * std::numbers::pi);
    const Vector3d MR = rs.radius / h * Vector3d(m0, m1, m1);
    const Matrix3d A = L * MR.asDiagonal() + Matrix3d::Identity();
    st.nu = A.partialPivLu().solve(L * (MR.asDiagonal() * st.nu + F));
  }
}

}  // namespace cosim::smooth
