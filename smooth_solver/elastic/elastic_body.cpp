#include "smooth_solver/elastic/elastic_body.h"

#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <set>

#include "interface/base/errors.h"
#include "interface/scenario/checks.h"

namespace cosim::smooth {

ElasticMesh BeamMesh(double length, double chord, double thickness, int along, int across_y, int across_z,
                     const std::vector<double>& twist) {
  ElasticMesh mesh;
  const int nx = 2 * along + 1, ny = 2 * across_y + 1, nz = 2 * across_z + 1;
  mesh.nodes.resize(3, nx * ny * nz);
  auto id = [&](int i, int j, int k) { return i + nx * (j + ny * k); };
  for (int k = 0; k < nz; ++k) {
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        const double x = length * i / (nx - 1);
        const double y = chord * (static_cast<double>(j) / (ny - 1) - 0.5);
        const double z = thickness * (static_cast<double>(k) / (nz - 1) - 0.5);
        double angle = 0.0;
        if (twist.size() == 1) angle = twist[0];
        if (twist.size() >= 2) {
          const double s = (static_cast<double>(twist.size()) - 1.0) * i / (nx - 1);
          const size_t seg = std::min(static_cast<size_t>(s), twist.size() - 2);
          const double u = s - static_cast<double>(seg);
          angle = (1.0 - u) * twist[seg] + u * twist[seg + 1];
        }
        mesh.nodes.col(id(i, j, k)) << x, std::cos(angle) * y - std::sin(angle) * z,
            std::sin(angle) * y + std::cos(angle) * z;
        if (i == 0) mesh.root_face.push_back(id(i, j, k));
        if (i == nx - 1) mesh.tip_face.push_back(id(i, j, k));
      }
    }
  }
  mesh.root_centre = id(0, (ny - 1) / 2, (nz - 1) / 2);
  mesh.tip_centre = id(nx - 1, (ny - 1) / 2, (nz - 1) / 2);
  for (int ek = 0; ek < across_z; ++ek) {
    for (int ej = 0; ej < across_y; ++ej) {
      for (int ei = 0; ei < along; ++ei) {
        std::array<int, 27> element{};
        for (int k = 0; k < 3; ++k) {
          for (int j = 0; j < 3; ++j) {
            for (int i = 0; i < 3; ++i)
              element[static_cast<size_t>(i + 3 * j + 9 * k)] = id(2 * ei + i, 2 * ej + j, 2 * ek + k);
          }
        }
        mesh.elements.push_back(element);
      }
    }
  }
  return mesh;
}

int ElasticBody::Initialize(ElasticMesh mesh, const ElasticMaterial& material) {
  mesh_ = std::move(mesh);
  material_ = material;
  elements_.resize(mesh_.elements.size());
  for (size_t e = 0; e < mesh_.elements.size(); ++e) {
    Hex27::NodeMatrix X;
    for (int a = 0; a < Hex27::kNodes; ++a) X.col(a) = mesh_.nodes.col(mesh_.elements[e][static_cast<size_t>(a)]);
    if (!elements_[e].Initialize(X)) return static_cast<int>(e);
  }
  return -1;
}

namespace {

// Collects triplets (for the static solver's stand-alone matrix).
class TripletSink : public SparseSink {
 public:
  void Add(int row, int column, double value) override { triplets.emplace_back(row, column, value); }
  std::vector<Eigen::Triplet<double>> triplets;
};

}  // namespace

namespace {

using ElementNodes = std::array<int, Hex27::kNodes>;

Hex27::NodeMatrix Gather(const ElasticBody::Positions& x, const ElementNodes& nodes) {
  Hex27::NodeMatrix xe;
  for (int a = 0; a < Hex27::kNodes; ++a) xe.col(a) = x.col(nodes[static_cast<size_t>(a)]);
  return xe;
}

void ScatterForce(const ElementNodes& nodes, const Hex27::ElementVector& fe, double scale,
                  Eigen::Ref<Eigen::VectorXd> f) {
  for (int a = 0; a < Hex27::kNodes; ++a)
    f.segment<3>(3 * nodes[static_cast<size_t>(a)]) += scale * fe.segment<3>(3 * a);
}

void ScatterMatrix(const ElementNodes& nodes, const Hex27::ElementMatrix& Ke, double scale, SparseSink* K, int offset) {
  std::array<int, 3 * Hex27::kNodes> index;  // Ke is node-major: 3a + i
  for (int a = 0; a < Hex27::kNodes; ++a) {
    for (int i = 0; i < 3; ++i) index[static_cast<size_t>(3 * a + i)] = offset + 3 * nodes[static_cast<size_t>(a)] + i;
  }
  K->AddDense(index.data(), 3 * Hex27::kNodes, Ke.data(), scale);
}

// The element results of one assembly, kept between calls (one set per calling thread: an
// assembly allocates nothing once its largest body has been seen; a tangent's 81 × 81 blocks
// are 52 kB each).
struct ElementWork {
  std::vector<Hex27::ElementVector> forces;
  std::vector<Hex27::ElementMatrix> matrices;

  static ElementWork& Get(size_t elements, bool tangent) {
    thread_local ElementWork work;
    if (work.forces.size() < elements) work.forces.resize(elements);
    if (tangent && work.matrices.size() < elements) work.matrices.resize(elements);
    return work;
  }
};

}  // namespace

void ElasticBody::AssembleMidpoint(const Positions& x_prev, const Positions& x, MidpointWeights weights, double f_scale,
                                   Eigen::Ref<Eigen::VectorXd> f, double k_scale, SparseSink* K, int offset) const {
  const bool force = f_scale != 0.0;
  ElementWork& work = ElementWork::Get(elements_.size(), K != nullptr);
  // Each element's force and tangent on whichever core is free (they only read the body and
  // the positions), scattered below in element order: the sums are the serial loop's, bit for bit.
#pragma omp parallel for schedule(dynamic, 1) if (elements_.size() > 1)
  for (size_t e = 0; e < elements_.size(); ++e) {
    const auto& nodes = mesh_.elements[e];
    elements_[e].MidpointForce(material_, Gather(x_prev, nodes), Gather(x, nodes), weights,
                               force ? &work.forces[e] : nullptr, K != nullptr ? &work.matrices[e] : nullptr);
  }
  for (size_t e = 0; e < elements_.size(); ++e) {
    if (force) ScatterForce(mesh_.elements[e], work.forces[e], f_scale, f);
    if (K != nullptr) ScatterMatrix(mesh_.elements[e], work.matrices[e], k_scale, K, offset);
  }
}

void ElasticBody::AssembleViscous(const Positions& x, const Positions& v, double retardation, double f_scale,
                                  Eigen::Ref<Eigen::VectorXd> f, double k_scale, double c_scale, SparseSink* K,
                                  int offset) const {
  const bool force = f_scale != 0.0;
  const bool tangent = K != nullptr && (k_scale != 0.0 || c_scale != 0.0);
  ElementWork& work = ElementWork::Get(elements_.size(), tangent);
#pragma omp parallel for schedule(dynamic, 1) if (elements_.size() > 1)
  for (size_t e = 0; e < elements_.size(); ++e) {
    const auto& nodes = mesh_.elements[e];
    elements_[e].ViscousForce(material_, retardation, Gather(x, nodes), Gather(v, nodes),
                              force ? &work.forces[e] : nullptr, k_scale, c_scale,
                              tangent ? &work.matrices[e] : nullptr);
  }
  for (size_t e = 0; e < elements_.size(); ++e) {
    if (force) ScatterForce(mesh_.elements[e], work.forces[e], f_scale, f);
    if (tangent) ScatterMatrix(mesh_.elements[e], work.matrices[e], 1.0, K, offset);
  }
}

void ElasticBody::Assemble(const Eigen::Matrix3Xd& x, Eigen::VectorXd* f, Eigen::SparseMatrix<double>* K) const {
  const int n = 3 * node_count();
  Eigen::VectorXd force = Eigen::VectorXd::Zero(n);
  TripletSink sink;
  if (K != nullptr) sink.triplets.reserve(mesh_.elements.size() * 81 * 81);
  AssembleMidpoint(x, x, MidpointWeights{}, 1.0, force, 1.0, K != nullptr ? &sink : nullptr, 0);
  if (f != nullptr) *f = std::move(force);
  if (K != nullptr) {
    K->resize(n, n);
    K->setFromTriplets(sink.triplets.begin(), sink.triplets.end());
  }
}

double ElasticBody::StrainEnergy(const Eigen::Ref<const Eigen::Matrix3Xd>& x) const {
  double energy = 0.0;
  for (size_t e = 0; e < elements_.size(); ++e) {
    Hex27::NodeMatrix xe;
    for (int a = 0; a < Hex27::kNodes; ++a) xe.col(a) = x.col(mesh_.elements[e][static_cast<size_t>(a)]);
    energy += elements_[e].StrainEnergy(material_, xe);
  }
  return energy;
}

std::vector<double> ElasticBody::VonMisesStress(const Eigen::Ref<const Eigen::Matrix3Xd>& x) const {
  std::vector<double> stress(elements_.size());
  for (size_t e = 0; e < elements_.size(); ++e)
    stress[e] = elements_[e].VonMisesStress(material_, Gather(x, mesh_.elements[e]));
  return stress;
}

Eigen::SparseMatrix<double> ElasticBody::MassMatrix() const {
  std::vector<Eigen::Triplet<double>> triplets;
  for (size_t e = 0; e < elements_.size(); ++e) {
    const auto Me = elements_[e].ScalarMass(material_.density);
    const auto& nodes = mesh_.elements[e];
    for (int a = 0; a < Hex27::kNodes; ++a) {
      for (int b = 0; b < Hex27::kNodes; ++b) {
        for (int i = 0; i < 3; ++i) {
          triplets.emplace_back(3 * nodes[static_cast<size_t>(a)] + i, 3 * nodes[static_cast<size_t>(b)] + i, Me(a, b));
        }
      }
    }
  }
  Eigen::SparseMatrix<double> M(3 * node_count(), 3 * node_count());
  M.setFromTriplets(triplets.begin(), triplets.end());
  return M;
}

StaticResult SolveStatic(const ElasticBody& body, const std::vector<int>& fixed,
                         const std::vector<std::pair<int, Eigen::Vector3d>>& loads, double tolerance,
                         int max_iterations, const Eigen::Matrix3Xd* start) {
  const int nodes = body.node_count(), n = 3 * nodes;
  // Free degrees of freedom, numbered compactly.
  const std::set<int> held(fixed.begin(), fixed.end());
  std::vector<int> free_index(static_cast<size_t>(n), -1);
  int nf = 0;
  for (int a = 0; a < nodes; ++a) {
    if (held.count(a) != 0) continue;
    for (int i = 0; i < 3; ++i) free_index[static_cast<size_t>(3 * a + i)] = nf++;
  }
  Eigen::VectorXd f_ext = Eigen::VectorXd::Zero(n);
  for (const auto& [node, force] : loads) f_ext.segment<3>(3 * node) += force;
  Eigen::Matrix3Xd x = start != nullptr ? *start : body.mesh().nodes;
  for (int a : fixed) x.col(a) = body.mesh().nodes.col(a);
  StaticResult result;
  Eigen::VectorXd f_int, r(nf);
  Eigen::SparseMatrix<double> K;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
  for (int it = 0; it <= max_iterations; ++it) {
    body.Assemble(x, &f_int, &K);
    // Relative to the loads and to the internal forces (the reactions at held nodes): the
    // round-off floor of f_int is about 1e-16 of the stiffness times the displacement.
    const double scale = std::max({1.0, f_ext.lpNorm<Eigen::Infinity>(), f_int.lpNorm<Eigen::Infinity>()});
    for (int d = 0; d < n; ++d) {
      if (free_index[static_cast<size_t>(d)] >= 0) r(free_index[static_cast<size_t>(d)]) = f_ext(d) - f_int(d);
    }
    result.residual = r.lpNorm<Eigen::Infinity>();
    result.iterations = it;
    if (result.residual <= tolerance * scale) break;
    if (it == max_iterations) {
      throw NumericalError("static solve: residual " + interface::FormatNumber(result.residual) + " N after " +
                           std::to_string(max_iterations) + " Newton iterations");
    }
    // Restrict K to the free degrees of freedom.
    std::vector<Eigen::Triplet<double>> t;
    t.reserve(static_cast<size_t>(K.nonZeros()));
    for (int k = 0; k < K.outerSize(); ++k) {
      for (Eigen::SparseMatrix<double>::InnerIterator e(K, k); e; ++e) {
        const int i = free_index[static_cast<size_t>(e.row())], j = free_index[static_cast<size_t>(e.col())];
        if (i >= 0 && j >= 0) t.emplace_back(i, j, e.value());
      }
    }
    Eigen::SparseMatrix<double> Kf(nf, nf);
    Kf.setFromTriplets(t.begin(), t.end());
    if (it == 0) ldlt.analyzePattern(Kf);
    ldlt.factorize(Kf);
    if (ldlt.info() != Eigen::Success) throw NumericalError("static solve: singular tangent stiffness");
    const Eigen::VectorXd dx = ldlt.solve(r);
    for (int a = 0; a < nodes; ++a) {
      for (int i = 0; i < 3; ++i) {
        const int fi = free_index[static_cast<size_t>(3 * a + i)];
        if (fi >= 0) x(i, a) += dx(fi);
      }
    }
    // Positions carry ~1e-16 of their size: a correction at that level cannot reduce the
    // residual further (its floor is then the stiffness times that round-off).
    if (dx.lpNorm<Eigen::Infinity>() <= 1e-13 * std::max(1.0, body.mesh().nodes.lpNorm<Eigen::Infinity>())) {
      body.Assemble(x, &f_int, nullptr);
      for (int d = 0; d < n; ++d) {
        if (free_index[static_cast<size_t>(d)] >= 0) r(free_index[static_cast<size_t>(d)]) = f_ext(d) - f_int(d);
      }
      result.residual = r.lpNorm<Eigen::Infinity>();
      result.iterations = it + 1;
      break;
    }
  }
  result.displacement = x - body.mesh().nodes;
  return result;
}

}  // namespace cosim::smooth
