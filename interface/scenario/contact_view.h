#pragma once
// The part of a scenario a contact process reads (issue 51, item 11). A coupled run's contact
// process builds its nodes, obstacles, springs and probes; of the smooth model it needs only the
// names its probes may give (recorded by smooth_solver: bodies, joints, elastic bodies, forces,
// beams and their node bodies, aero surfaces and rotors). Expanding every pattern copy of the
// whole model (beam stations, meshes, airfoil tables, airwake grids) cost each process ~0.44 ms a
// blade, and one process per blade made the run's start O(N²). The launcher and the coordinator
// load and check the whole scene; a contact process loads this view.
#include <string>
#include <vector>

#include "scenario.pb.h"

namespace cosim::interface {

struct PathSegment;

// Which part of a scenario a program loads.
enum class ScenarioView {
  kWhole,           // every field (the launcher, smooth_solver, a standalone contact run)
  kContactProcess,  // the smooth model reduced to its names (a coupled run's contact process)
};

// Reduces the smooth model's elements to what a contact process reads of them: each body, joint,
// elastic body and force its name; each beam its name, elements and nodes_per_element (its
// node bodies' names); the air its surfaces' and rotors' names. Contact nodes, obstacles, node
// springs, frames, moving bases and initial conditions stay whole.
void ReduceToContactView(scenario::Model* model);

// True if the view reduces away the field at `segments` (a `--set` path): a field of a smooth
// element below what ReduceToContactView keeps. Such an override is smooth_solver's to apply
// and check.
bool OutsideContactView(const std::vector<PathSegment>& segments);

}  // namespace cosim::interface
