#pragma once
// The hub of a Newton matrix: the body that all the others hang from, in three or more parts.
// A rotor's blades are joined to one another only through the hub; ordered last, its columns
// leave each blade's block to be factorised on its own, and the factors grow with the number of
// blades (docs/performance.md, "Large legal rotors"). A fill-reducing ordering that does not know
// this eliminates the hub's columns among the blades' and fills the factors between blades.
#include <Eigen/SparseCore>
#include <vector>

#include "smooth_solver/linear_algebra/klu_solver.h"

namespace cosim::smooth {

// The columns of A's hub: of a group of columns (group[j] >= 0; −1 marks a column that is a
// group of its own) whose removal splits the graph of A + Aᵀ into three or more parts, none
// holding more than half of the columns left (no part is "the rest of the model": the group is
// its centre). Sorted; empty when A has no such group.
std::vector<int> HubColumns(const Eigen::SparseMatrix<double>& A, const std::vector<int>& group);

// The column groups of a multibody Newton matrix: each rigid body's coordinates (the first
// `rigid_coordinates` columns, in blocks of kCoordinatesPerBody) a group, every other column
// (elastic nodes' coordinates, multipliers) its own.
std::vector<int> RigidBodyGroups(int rigid_coordinates, int columns);

// A one-off factorisation of a multibody matrix (the rigid bodies' coordinates first,
// `rigid_coordinates` of them) with its hub's columns last, as the Newton matrices are: the
// consistent accelerations, the impact restarts' projections. Eigen's SparseLU with COLAMD,
// which these used, filled the factors between blades (~7 s of a 200-blade rotor's start).
// `A` is made compressed. False if A is singular.
[[nodiscard]] bool FactorizeHubLast(Eigen::SparseMatrix<double>* A, int rigid_coordinates, KluSolver* lu);

}  // namespace cosim::smooth
