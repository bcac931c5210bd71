#include "smooth_solver/linear_algebra/hub_columns.h"

#include <algorithm>

#include "smooth_solver/constraints/bilinear_constraints.h"

namespace cosim::smooth {

namespace {

// The graph of A + Aᵀ with each group of columns one vertex: adjacency lists (CSR).
struct GroupGraph {
  std::vector<int> start, next;  // the neighbours of v: next[start[v] .. start[v + 1])
  std::vector<long> weight;      // columns per vertex
  int groups = 0;                // vertices 0 .. groups − 1 are the groups, the rest single columns
};

GroupGraph BuildGraph(const Eigen::SparseMatrix<double>& A, const std::vector<int>& group) {
  const int n = static_cast<int>(A.cols());
  GroupGraph g;
  for (int j = 0; j < n; ++j) g.groups = std::max(g.groups, group[static_cast<size_t>(j)] + 1);
  std::vector<int> vertex(static_cast<size_t>(n));
  int vertices = g.groups;
  for (int j = 0; j < n; ++j) {
    const int k = group[static_cast<size_t>(j)];
    vertex[static_cast<size_t>(j)] = k >= 0 ? k : vertices++;
  }
  std::vector<std::pair<int, int>> edges;
  edges.reserve(2 * static_cast<size_t>(A.nonZeros()));
  for (int j = 0; j < n; ++j) {
    for (Eigen::SparseMatrix<double>::InnerIterator it(A, j); it; ++it) {
      const int u = vertex[static_cast<size_t>(it.row())], v = vertex[static_cast<size_t>(j)];
      if (u != v) {
        edges.emplace_back(u, v);
        edges.emplace_back(v, u);
      }
    }
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  g.start.assign(static_cast<size_t>(vertices) + 1, 0);
  for (const auto& e : edges) ++g.start[static_cast<size_t>(e.first) + 1];
  for (size_t v = 0; v < static_cast<size_t>(vertices); ++v) g.start[v + 1] += g.start[v];
  g.next.reserve(edges.size());
  for (const auto& e : edges) g.next.push_back(e.second);  // (sorted by source)
  g.weight.assign(static_cast<size_t>(vertices), 0);
  for (int j = 0; j < n; ++j) ++g.weight[static_cast<size_t>(vertex[static_cast<size_t>(j)])];
  return g;
}

// Tarjan's articulation points, iteratively (a rotor's blades make deep chains), with the
// weight of each part a vertex's removal leaves. Returns the group vertices that qualify.
std::vector<int> CentreGroups(const GroupGraph& g) {
  const size_t vertices = g.weight.size();
  std::vector<int> disc(vertices, -1), low(vertices, 0), parent(vertices, -1), edge(vertices, 0);
  std::vector<long> below(vertices, 0);      // the weight of v's DFS subtree
  std::vector<long> separated(vertices, 0);  // weight of the parts v's removal cuts off below it
  std::vector<int> parts(vertices, 0);       // their number
  std::vector<long> largest(vertices, 0);    // the largest of them
  std::vector<int> centres;
  int clock = 0;
  for (size_t root = 0; root < vertices; ++root) {
    if (disc[root] >= 0) continue;
    std::vector<int> stack{static_cast<int>(root)}, order;
    disc[root] = low[root] = clock++;
    edge[root] = g.start[root];
    while (!stack.empty()) {
      const int v = stack.back();
      const auto vs = static_cast<size_t>(v);
      if (edge[vs] < g.start[vs + 1]) {
        const int w = g.next[static_cast<size_t>(edge[vs]++)];
        const auto ws = static_cast<size_t>(w);
        if (disc[ws] < 0) {
          parent[ws] = v;
          disc[ws] = low[ws] = clock++;
          edge[ws] = g.start[ws];
          stack.push_back(w);
        } else if (w != parent[vs]) {
          low[vs] = std::min(low[vs], disc[ws]);
        }
        continue;
      }
      stack.pop_back();
      order.push_back(v);
      below[vs] += g.weight[vs];
      const int p = parent[vs];
      if (p < 0) continue;
      const auto ps = static_cast<size_t>(p);
      low[ps] = std::min(low[ps], low[vs]);
      below[ps] += below[vs];
      if (low[vs] >= disc[ps]) {  // removing p cuts v's subtree off
        ++parts[ps];
        separated[ps] += below[vs];
        largest[ps] = std::max(largest[ps], below[vs]);
      }
    }
    const long total = below[root];
    for (const int v : order) {
      const auto vs = static_cast<size_t>(v);
      if (v >= g.groups) continue;
      int count = parts[vs];
      long big = largest[vs];
      const long rest = total - g.weight[vs] - separated[vs];  // the part above v (none for the root)
      if (rest > 0) {
        ++count;
        big = std::max(big, rest);
      }
      if (count >= 3 && 2 * big <= total - g.weight[vs]) centres.push_back(v);
    }
  }
  return centres;
}

}  // namespace

std::vector<int> HubColumns(const Eigen::SparseMatrix<double>& A, const std::vector<int>& group) {
  const GroupGraph g = BuildGraph(A, group);
  const std::vector<int> centres = CentreGroups(g);
  std::vector<int> columns;
  for (int j = 0; j < static_cast<int>(A.cols()); ++j) {
    if (std::find(centres.begin(), centres.end(), group[static_cast<size_t>(j)]) != centres.end()) columns.push_back(j);
  }
  return columns;
}

std::vector<int> RigidBodyGroups(int rigid_coordinates, int columns) {
  std::vector<int> group(static_cast<size_t>(columns), -1);
  for (int j = 0; j < rigid_coordinates; ++j) group[static_cast<size_t>(j)] = j / kCoordinatesPerBody;
  return group;
}

bool FactorizeHubLast(Eigen::SparseMatrix<double>* A, int rigid_coordinates, KluSolver* lu) {
  A->makeCompressed();
  lu->Analyze(*A, HubColumns(*A, RigidBodyGroups(rigid_coordinates, static_cast<int>(A->cols()))));
  return lu->Factorize(*A);
}

}  // namespace cosim::smooth
