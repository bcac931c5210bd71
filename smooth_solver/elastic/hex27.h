#pragma once
// The 27-node hexahedron with tri-quadratic Lagrange shape functions, total Lagrangian, for
// a Saint Venant–Kirchhoff material [CGα paper, Section 3, Eqs. (10)-(19)].
//
// Node numbering: node = i + 3 j + 9 k for the reference coordinates
// (ξ, η, ζ) = (−1, 0, 1)[i], (−1, 0, 1)[j], (−1, 0, 1)[k]. Integration: 3×3×3 Gauss points
// (exact for the consistent mass matrix).
//
// With F = I + H, H = Σ_a (x_a − X_a) ⊗ ∇_X N_a, E = ½ (H + Hᵀ + HᵀH) (computed from the
// displacement gradient: for the tiny strains of a stiff blade, ½(FᵀF − I) would lose the
// strain's leading digits to cancellation) and S = λ tr(E) I + 2μ E:
//   f_int,a = ∫ F S ∇N_a dV,
//   K_ab = ∫ (∇N_a · S ∇N_b) I dV + ∫ [λ (F∇N_a)(F∇N_b)ᵀ + μ ((∇N_a·∇N_b) FFᵀ + (F∇N_b)(F∇N_a)ᵀ)] dV,
//   M_ab = ∫ ρ N_a N_b dV I.
//
// The GEMM midpoint internal force [CGα paper, Eqs. (13)-(19); Kuhl & Crisfield 1999] over a
// step x_n → x_{n+1} uses F_m = (1 − αf) F_{n+1} + αf F_n (Eq. (15)) and
// S_m = C : ((1 − αf + ξ) E_{n+1} + (αf − ξ) E_n) (Eq. (16)):
//   f_m,a = ∫ F_m S_m ∇N_a dV                                                            Eq. (13)
// and its derivative with respect to x_{n+1} (Eq. (18), written out for isotropic C):
//   K_ab = ∫ (1 − αf)(∇N_a · S_m ∇N_b) I dV
//        + ∫ (1 − αf + ξ)[λ (F_m∇N_a)(F_{n+1}∇N_b)ᵀ + μ ((∇N_a·∇N_b) F_m F_{n+1}ᵀ + (F_m∇N_b)(F_{n+1}∇N_a)ᵀ)] dV,
// not symmetric unless x_n = x_{n+1}. Since E_{n+1} − E_n = sym(F_mᵀ (F_{n+1} − F_n)) exactly
// for αf = ½, f_m · (x_{n+1} − x_n) = W(x_{n+1}) − W(x_n) when αf = ½, ξ = 0: the strain
// energy's increment is the midpoint force's work, which is what conserves energy.
// With αf = ξ = 0 the midpoint force is the end-point force above.
#include <Eigen/Core>
#include <array>

namespace cosim::smooth {

struct ElasticMaterial {
  double density = 0.0;  // [kg/m³]
  double young = 0.0;    // [Pa]
  double poisson = 0.0;  // in (−1, 0.5)
  double lambda() const { return young * poisson / ((1.0 + poisson) * (1.0 - 2.0 * poisson)); }
  double mu() const { return young / (2.0 * (1.0 + poisson)); }
};

// The weights of the GEMM midpoint (Eqs. (15)-(16)); the default is the end-point force.
struct MidpointWeights {
  double alpha_f = 0.0;  // weight of the step's start
  double xi = 0.0;       // strain damping ξ (Eq. (17))
};

class Hex27 {
 public:
  static constexpr int kNodes = 27;
  static constexpr int kGauss = 27;
  using NodeMatrix = Eigen::Matrix<double, 3, kNodes>;         // one column per node
  using ElementVector = Eigen::Matrix<double, 3 * kNodes, 1>;  // node-major: 3a + i
  using ElementMatrix = Eigen::Matrix<double, 3 * kNodes, 3 * kNodes>;

  // Precomputes the reference gradients and volume weights from the reference node
  // positions. Returns false if the element is inverted or degenerate (det J <= 0 at a
  // Gauss point).
  [[nodiscard]] bool Initialize(const NodeMatrix& reference);

  // Internal force (and optionally the tangent) at current node positions x.
  void InternalForce(const ElasticMaterial& m, const NodeMatrix& x, ElementVector* f, ElementMatrix* K) const {
    MidpointForce(m, x, x, MidpointWeights{}, f, K);
  }
  // GEMM midpoint force over the step x_prev → x (and optionally its derivative by x).
  void MidpointForce(const ElasticMaterial& m, const NodeMatrix& x_prev, const NodeMatrix& x, MidpointWeights w,
                     ElementVector* f, ElementMatrix* K) const;
  // Kelvin–Voigt viscous force at positions x and velocities v: S_v = β C : Ė with
  // Ė = sym(Fᵀ Ḟ) (objective: no force for a rigid motion), f_a = ∫ F S_v ∇N_a dV; optionally
  // the combined tangent KC = k_scale ∂f/∂x + c_scale ∂f/∂v (∂f/∂v is β times the material
  // stiffness), in one pass: both are material blocks, linear in Ḟ resp. F on one side.
  // β: retardation time [s], which damps a mode of frequency ω with the ratio ζ = βω/2.
  void ViscousForce(const ElasticMaterial& m, double retardation, const NodeMatrix& x, const NodeMatrix& v,
                    ElementVector* f, double k_scale, double c_scale, ElementMatrix* KC) const;
  // Strain energy ∫ ½ E : C : E dV.
  double StrainEnergy(const ElasticMaterial& m, const NodeMatrix& x) const;
  // The von Mises equivalent of the Cauchy stress σ = F S Fᵀ / det F, averaged over the
  // element's volume (its Gauss points) [Pa]: what the visual output colours an element by.
  double VonMisesStress(const ElasticMaterial& m, const NodeMatrix& x) const;
  // Consistent mass matrix (the 27×27 scalar part; the 3×3 blocks are this × I).
  Eigen::Matrix<double, kNodes, kNodes> ScalarMass(double density) const;
  double Volume() const;

  // 1D quadratic Lagrange shape functions at s ∈ [−1, 1] and their derivatives.
  static std::array<double, 3> Shape1D(double s);
  static std::array<double, 3> Shape1DDerivative(double s);

 private:
  // ∇_X N_a at each Gauss point (3 × 27) and the volume weight w |det J|.
  std::array<Eigen::Matrix<double, 3, kNodes>, kGauss> grad_;
  std::array<Eigen::Matrix<double, kNodes, 1>, kGauss> shape_;
  std::array<double, kGauss> weight_{};
  NodeMatrix reference_;  // X, so that strains come from displacements (no I − I cancellation)
};

}  // namespace cosim::smooth
