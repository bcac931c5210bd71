#pragma once
// Visual output (scenario `output { visual { every: N } }`): a time series that ParaView opens
// as it is — one VTK XML UnstructuredGrid file (.vtu, inline base64 binary arrays) per frame in the run's `visual/`
// folder and a ParaView data collection (`visual.pvd`) indexing them by time, rewritten after
// every frame so that a failed run keeps every frame up to its last accepted step.
//
// Why a writer of our own and not VTK's C++ API: a frame is points, cells of six types and a
// few data arrays; the writer is ~150 lines, while VTK would add a dependency of several hundred
// MB to both solvers. It is tested against a reader (meshio, tests/integration/visual_test).
//
// One frame holds every entity of a process, told apart by two cell arrays: `kind` (Kind below)
// and `entity` (the index of the entity among those of its kind, named in visual/legend.csv),
// plus `in_contact` (contact nodes and stop planes: 1 while in contact) and `von_mises` (hex27
// elements [Pa]); the point array `displacement` [m] is the hex27 nodes' displacement from the
// reference configuration (zero elsewhere).
#include <Eigen/Core>
#include <string>
#include <vector>

namespace cosim::interface {

class VisualFrame {
 public:
  enum class Kind {
    kBodyAxis = 0,     // a rigid body's frame: three lines from its origin along its axes
    kBodyShape = 1,    // a rigid body's shape: lines from its origin to its joints' points, and
                       // the box (in its axes) around them
    kBeamAxis = 2,     // a beam's nodes joined by lines
    kBeamSection = 3,  // a beam: each node's chordwise section line, and quads between them
    kSolid = 4,        // a hex27 element (tri-quadratic hexahedron)
    kTie = 5,          // a coupling tie: the body point to the contact node it follows
    kContactNode = 6,  // a contact node (vertex)
    kObstacle = 7,     // a stop plane (a square patch around the nodes that can touch it)
  };
  // VTK cell types used.
  static constexpr int kVertex = 1, kLine = 3, kQuad = 9, kHexahedron = 12, kTriQuadraticHexahedron = 29;

  int AddPoint(const Eigen::Vector3d& x, const Eigen::Vector3d& displacement = Eigen::Vector3d::Zero());
  void AddCell(int vtk_type, const std::vector<int>& points, Kind kind, int entity, int in_contact = 0,
               double von_mises = 0.0);
  // A plane drawn as the square of half-side `half` about `centre` spanned by the unit vectors
  // t1, t2 (a stop plane, infinite in the model).
  void AddSquare(const Eigen::Vector3d& centre, const Eigen::Vector3d& t1, const Eigen::Vector3d& t2, double half,
                 Kind kind, int entity, int in_contact);
  // The entity's name in visual/legend.csv (first frame); index = its order within its kind.
  void Name(Kind kind, int entity, const std::string& name);

  int points() const { return static_cast<int>(x_.size()); }
  int cells() const { return static_cast<int>(type_.size()); }
  const std::vector<std::string>& legend() const { return legend_; }

  // Writes the frame as a .vtu file; throws InputError naming the file if it cannot.
  void WriteVtu(const std::string& path, double time) const;

 private:
  std::vector<Eigen::Vector3d> x_, displacement_;
  std::vector<int> connectivity_, offsets_, type_, kind_, entity_, in_contact_;
  std::vector<double> von_mises_;
  std::vector<std::string> legend_;  // "kind,entity,name" rows
};

// The run's visual output: `folder`/visual/NNNNNN.vtu, `folder`/visual.pvd, visual/legend.csv.
class VisualSeries {
 public:
  explicit VisualSeries(std::string folder);
  // Writes frame `frame` at `time` and rewrites the index. Throws InputError.
  void Write(const VisualFrame& frame, double time);
  int frames() const { return static_cast<int>(times_.size()); }

 private:
  std::string folder_;
  std::vector<double> times_;
  std::vector<std::string> files_;  // relative to folder_
};

// Reads the (time, file) entries of a visual.pvd this code wrote (files relative to its folder).
std::vector<std::pair<double, std::string>> ReadPvd(const std::string& path);
// Writes `path`, a .pvd of several processes' series as parts of one scene: each series'
// entries with their files prefixed by its folder relative to `path`'s.
void WriteScenePvd(const std::string& path, const std::vector<std::pair<std::string, std::string>>& series);

}  // namespace cosim::interface
