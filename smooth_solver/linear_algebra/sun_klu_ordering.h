#pragma once
// SUNDIALS's KLU (KINSOL's consistent initial state) with columns ordered last, as KluSolver
// orders a hub's (hub_columns.h): COLAMD constrained by SuiteSparse's ccolamd.
#include <sunlinsol/sunlinsol_klu.h>

#include <vector>

namespace cosim::smooth {

// The ordering of `common` (SUNLinSol_KLUGetCommon, before the solver's first setup) keeps the
// columns `last` of its n × n matrices after all others; `sets` holds ccolamd's constraint sets
// and must outlive the solver's analysis. Nothing changes when `last` is empty.
void OrderColumnsLast(sun_klu_common* common, int n, const std::vector<int>& last, std::vector<sunindextype>* sets);

}  // namespace cosim::smooth
