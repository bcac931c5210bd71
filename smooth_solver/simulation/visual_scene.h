#pragma once
// The smooth model drawn for the visual output (interface/visual/visual_frame.h): rigid bodies
// as their frames, the lines from their origins to their joints' and ties' points and the box
// around those points in the body's axes, beams as
// the lines joining their nodes with each node's chordwise section line and the quads between
// them (a ribbon of the blade), hex27 bodies as their tri-quadratic elements with nodal
// displacement and each element's von Mises stress, and each coupling tie as the line from
// its body point to the contact node the peer imposes.
#include <Eigen/Core>
#include <string>

#include "interface/visual/visual_frame.h"
#include "smooth_solver/model/multibody_model.h"
#include "smooth_solver/model/multibody_system.h"

namespace cosim::smooth {

struct VisualSettings {
  double axis_length = 0.0;  // rigid bodies' frame axes [m]; 0: a quarter of each body's size
};

// `data`: the run's changing state (the ties' far ends are the imposed coordinates).
void DrawScene(const MultibodyModel& model, const MultibodySystem& system, const SystemData& data,
               const Eigen::VectorXd& q, const VisualSettings& settings, interface::VisualFrame* frame);

// One hex27 body at nodal positions x (3 × nodes): its elements as VTK tri-quadratic
// hexahedra, each node's displacement from the mesh and each element's von Mises stress, as
// solid `index` named `name` (the STATIC hex27 analysis draws its bodies with it too).
void DrawHex27Body(const ElasticBody& body, const std::string& name, int index,
                   const Eigen::Ref<const Eigen::Matrix3Xd>& x, interface::VisualFrame* frame);

// VTK's tri-quadratic hexahedron (cell type 29) numbers its nodes: corners, edge midpoints,
// face centres (−x, +x, −y, +y, −z, +z), centre; entry k is the Hex27 node (i + 3j + 9k)
// at VTK's node k.
const std::array<int, 27>& VtkHex27Order();

}  // namespace cosim::smooth
