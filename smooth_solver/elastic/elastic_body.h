#pragma once
// An elastic body meshed with 27-node hexahedra: the mesh (built from a beam description or
// given node/element lists), the elements' precomputed reference data, the assembly of the
// internal force and tangent over the mesh, and a static solver (inertia off) for
// verification against static results [CGα paper, Section 5.1, Tables 1-2].
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <array>
#include <string>
#include <vector>

#include "smooth_solver/constraints/bilinear_constraints.h"
#include "smooth_solver/elastic/hex27.h"

namespace cosim::smooth {

struct ElasticMesh {
  Eigen::Matrix3Xd nodes;                     // reference positions [m]
  std::vector<std::array<int, 27>> elements;  // node indices, Hex27 numbering
  std::vector<int> root_face, tip_face;       // beam meshes: nodes at x = 0 and x = length
  int root_centre = -1, tip_centre = -1;      // beam meshes: nodes at the centres of the end faces
};

// A straight beam along +x from the origin: length × chord (y) × thickness (z), centred on
// the x axis, with `along` elements along x and `across_y`, `across_z` across. `twist`
// [rad], if given, is interpolated linearly over equally spaced stations root → tip and
// turns each cross-section about x.
ElasticMesh BeamMesh(double length, double chord, double thickness, int along, int across_y, int across_z,
                     const std::vector<double>& twist);

class ElasticBody {
 public:
  // Returns the index of the first inverted or degenerate element, or −1 if all are valid.
  int Initialize(ElasticMesh mesh, const ElasticMaterial& material);

  const ElasticMesh& mesh() const { return mesh_; }
  int node_count() const { return static_cast<int>(mesh_.nodes.cols()); }
  // The body's node triples in a system vector (positions q, or rates) whose slice starts at `offset`.
  Eigen::Map<const Eigen::Matrix3Xd> NodesIn(const Eigen::VectorXd& q, int offset) const {
    return Eigen::Map<const Eigen::Matrix3Xd>(q.data() + offset, 3, node_count());
  }
  // Internal force (3 per node) and, if K is given, the tangent, at current positions x.
  void Assemble(const Eigen::Matrix3Xd& x, Eigen::VectorXd* f, Eigen::SparseMatrix<double>* K) const;
  // The GEMM midpoint force over the step x_prev → x (Hex27::MidpointForce), assembled without
  // allocating: f_scale · f_m is added to `f` (3 per node); if `K` is given, k_scale · ∂f_m/∂x
  // is added into it at (offset + 3 node + i, offset + 3 node' + j).
  using Positions = Eigen::Ref<const Eigen::Matrix3Xd>;
  void AssembleMidpoint(const Positions& x_prev, const Positions& x, MidpointWeights weights, double f_scale,
                        Eigen::Ref<Eigen::VectorXd> f, double k_scale, SparseSink* K, int offset) const;
  // The Kelvin–Voigt viscous force (Hex27::ViscousForce) at positions x and velocities v:
  // f_scale · f_v added to `f`, and k_scale · ∂f_v/∂x + c_scale · ∂f_v/∂v into `K` (if given).
  void AssembleViscous(const Positions& x, const Positions& v, double retardation, double f_scale,
                       Eigen::Ref<Eigen::VectorXd> f, double k_scale, double c_scale, SparseSink* K, int offset) const;
  double StrainEnergy(const Eigen::Ref<const Eigen::Matrix3Xd>& x) const;
  // Each element's volume-averaged von Mises stress at node positions x [Pa] (Hex27).
  std::vector<double> VonMisesStress(const Eigen::Ref<const Eigen::Matrix3Xd>& x) const;
  Eigen::SparseMatrix<double> MassMatrix() const;  // 3 per node, consistent

 private:
  ElasticMesh mesh_;
  ElasticMaterial material_;
  std::vector<Hex27> elements_;
};

struct StaticResult {
  Eigen::Matrix3Xd displacement;
  int iterations = 0;
  double residual = 0.0;  // |f_int − f_ext|∞ on the free degrees of freedom [N]
};

// Newton–Raphson on f_int(x) = f_ext with the nodes in `fixed` held at their reference
// positions. `loads`: (node, force [N]). Converged when the free residual is at most
// tolerance × max(|f_ext|∞, |f_int|∞), or when the Newton correction is down to the
// round-off of the positions (1e-13 of their size). Throws NumericalError otherwise.
// `start`, if given, is the initial guess of the positions (e.g. the previous load step's).
StaticResult SolveStatic(const ElasticBody& body, const std::vector<int>& fixed,
                         const std::vector<std::pair<int, Eigen::Vector3d>>& loads, double tolerance,
                         int max_iterations, const Eigen::Matrix3Xd* start = nullptr);

}  // namespace cosim::smooth
