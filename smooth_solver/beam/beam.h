#pragma once
// A geometrically exact (Simo–Reissner) beam in director form (Betsch & Steinmann, IJNME 54
// (2002) 1775–1788; Romero & Armero 2002). Each beam node is a natural-coordinates frame
// q_I = [x_I, d1_I, d2_I, d3_I] — exactly a rigid body's 12 coordinates with its six
// orthonormality rows — so a node is a body of the multibody system: joints, probes, loads and
// contact ties work on it unchanged. d1 is the section normal (along the reference line), d2
// the chordwise and d3 the flapwise section axis.
//
// Along an element, positions and directors are interpolated with the same Lagrange shape
// functions N_I(s) (2 or 3 nodes). The strains are the Simo–Reissner ones written with
// directors (design.md, "Beam blades"):
//   Γ_1 = ½ r′ · r′ − Γ⁰_1                                 (axial: the reference line's stretch)
//   Γ_a = d_a · r′ − Γ⁰_a                                  (a = 2, 3: two shears)
//   κ_1 = ½ (d3 · d2′ − d2 · d3′) − κ⁰_1                   (torsion)
//   κ_2 = ½ (d1 · d3′ − d3 · d1′) − κ⁰_2                   (flapwise bending, about d2)
//   κ_3 = ½ (d2 · d1′ − d1 · d2′) − κ⁰_3                   (chordwise bending, about d3)
// With R = [d1 d2 d3] orthonormal these are Rᵀr′ − e1 (the axial one to second order: Green's
// ½(λ² − 1) for λ − 1) and axial(RᵀR′); between the nodes the interpolated directors are not
// orthonormal, and the bilinear forms above are what the strain energy is written in. The axial
// strain is not d_1 · r′: where neighbouring sections turn, the interpolated d_1 is shorter
// than 1 at the Gauss points, and a stretch of the reference line hid there without energy. A
// spinning blade's tension pays for that stretch, so it was a mode of negative stiffness: two
// teetering blades of 3 quadratic elements at 54.7 rad/s bent 8 m in lag within 0.1 s, in
// vacuum, in CGα and IDA alike (generated rotor 589).
// Every strain is a quadratic form in q, so its gradient B is linear in q, its Hessian is
// constant, and the tangent is exact in closed form:
//   V = Σ_g w_g J ½ εᵀ C ε,   f = −Σ_g w_g J Bᵀ C ε,   K = Σ_g w_g J (Bᵀ C B + Σ_k σ_k H_k).
// The reference strains Γ⁰, κ⁰ are those of the initial (pre-twisted) configuration, so the
// beam is stress-free there. Shear locking: reduced integration (n − 1 Gauss points for an
// n-node element). The mass matrix is constant: kinetic energy ½ ∫ (m |ṙ|² + 2 m c_a ṙ·ḋ_a +
// J_ab ḋ_a·ḋ_b) ds with J_ab = ∫ ρ η_a η_b dA.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <array>
#include <string>
#include <vector>

#include "smooth_solver/constraints/bilinear_constraints.h"
#include "smooth_solver/forces/force_elements.h"

namespace cosim::smooth {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

// Section properties at one point of the span. Section axes: 2 chordwise (d2), 3 flapwise (d3);
// offsets are measured from the reference line along them.
struct BeamSection {
  double ea = 0.0;                        // axial stiffness [N]
  double ga2 = 0.0, ga3 = 0.0;            // shear stiffness along d2, d3 [N]
  double gj = 0.0;                        // torsional stiffness [N m²]
  double ei2 = 0.0;                       // bending about d2: flapwise [N m²]
  double ei3 = 0.0;                       // bending about d3: chordwise (lag) [N m²]
  double tension2 = 0.0, tension3 = 0.0;  // tension-centre (elastic-axis) offset [m]
  double mass = 0.0;                      // per length [kg/m]
  double cg2 = 0.0, cg3 = 0.0;            // centre-of-mass offset [m]
  double inertia2 = 0.0;                  // ∫ρ(η3 − c3)² dA about the c.g.'s chordwise axis [kg m]
  double inertia3 = 0.0;                  // ∫ρ(η2 − c2)² dA about the c.g.'s flapwise axis [kg m]
  double twist = 0.0;                     // [rad] about d1, nose up positive
};

// The 6×6 section stiffness over ε = [Γ1, Γ2, Γ3, κ1, κ2, κ3]: the axial strain at the tension
// centre (η2, η3) = (t2, t3) is Γ1 + t3 κ2 − t2 κ3 (the fibre strain Γ + κ × η), bending is
// about axes through it, shear centre on the reference line.
Matrix6d SectionStiffness(const BeamSection& s);
// Second moments of the section's mass about the reference line, J_ab = ∫ ρ η_a η_b dA
// (a, b ∈ {2, 3}), and first moments m c_a.
Eigen::Matrix2d SectionSecondMoments(const BeamSection& s);

// Section data at stations along the span (s non-decreasing; two equal s make a step), linear
// in between, constant beyond the ends.
class BeamTable {
 public:
  BeamTable() = default;
  BeamTable(std::vector<double> s, std::vector<BeamSection> sections);
  // The section at s (at a step: the outboard side unless `inboard`).
  BeamSection At(double s, bool inboard = false) const;
  // Station coordinates strictly inside (a, b), sorted: where the data's slope may change.
  std::vector<double> BreaksWithin(double a, double b) const;

 private:
  std::vector<double> s_;
  std::vector<BeamSection> sections_;
};

// One element: its nodes (bodies), reference length and, per Gauss point, section stiffness
// and reference strains.
struct BeamElement {
  std::array<int, 3> node{-1, -1, -1};                       // body index of each node
  double s0 = 0.0, length = 0.0;                             // span coordinate of its first node, reference length
  std::array<Matrix6d, 2> stiffness;                         // C at each Gauss point
  std::array<Vector6d, 2> reference;                         // Γ⁰, κ⁰ at each Gauss point (set by BeamForce)
  Eigen::Matrix<double, 3 * kCoordinatesPerBody, 1> q_ref =  // reference coordinates, 12 per node
      Eigen::Matrix<double, 3 * kCoordinatesPerBody, 1>::Zero();
};

// Lagrange shape functions of an n-node element (n = 2, 3; equally spaced nodes on ξ ∈ [−1, 1]).
void BeamShape(int n, double xi, double* N, double* dN_dxi);
// Reduced Gauss rule: n − 1 points.
int BeamGaussPoints(int n, std::array<double, 2>* xi, std::array<double, 2>* weight);

// The element's constant mass matrix over slots (x, d1, d2, d3 of each node; a scalar matrix
// ⊗ I3 in coordinates), integrated exactly for data linear between stations. `rotary_floor`
// [m²] adds rotary_floor · m to every director's second moment (see beam_model.h).
Eigen::MatrixXd BeamElementMass(int n, double s0, double length, const BeamTable& table, double rotary_floor);

// A beam's internal and Kelvin–Voigt damping forces (σ_v = β C ε̇, ζ = βω/2 per mode), as one
// force element over all its elements (an end-point force for every integrator).
class BeamForce : public ForceElement {
 public:
  BeamForce(std::string name, int nodes_per_element, std::vector<BeamElement> elements, double retardation);
  void AddForce(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, const SystemData& data,
                Eigen::Ref<Eigen::VectorXd> f) const override;
  void AddTangent(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, const SystemData& data,
                  double stiffness_scale, double damping_scale, SparseSink* sink) const override;
  void Pattern(SparseSink* sink) const override;
  double PotentialEnergy(const Eigen::VectorXd& q) const override;

  // Section forces and moments σ = C ε = [N, V2, V3, T, M2, M3] (section frame) at span
  // coordinate s, from the Gauss points of the element containing it (constant over a 2-node
  // element, linear through a 3-node element's two points).
  Vector6d SectionForces(const Eigen::VectorXd& q, double s) const;
  const std::vector<BeamElement>& elements() const { return elements_; }
  int nodes_per_element() const { return n_; }

  static constexpr int kMaxLocal = 3 * kCoordinatesPerBody;
  using Local = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxLocal, 1>;
  using LocalMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kMaxLocal, kMaxLocal>;
  using StrainGradient = Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::RowMajor, 6, kMaxLocal>;

  // The element's strains at its Gauss point g from its local coordinates ql (12 per node), and
  // their gradient.
  void Strains(const BeamElement& e, const Local& ql, int g, Vector6d* eps, StrainGradient* B) const;

 private:
  void Gather(const BeamElement& e, const Eigen::VectorXd& q, Local* ql) const;
  // Adds the element's contributions: f_l += force; K_l, C_l (if given) += tangents.
  void Element(const BeamElement& e, const Local& ql, const Local& vl, Local* f, LocalMatrix* K, LocalMatrix* C,
               double* energy) const;

  std::string name_;
  int n_;
  std::vector<BeamElement> elements_;
  double retardation_;
  std::array<double, 2> xi_{}, w_{};
  // Shape functions N_I and dN_I/dξ at each Gauss point (computed once).
  std::array<std::array<double, 3>, 2> shape_{}, shape_xi_{};
  int gauss_ = 1;
};

}  // namespace cosim::smooth
