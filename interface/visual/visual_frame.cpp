#include "interface/visual/visual_frame.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <utility>

#include "interface/run/errors.h"

namespace cosim::interface {

namespace {

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};

// Opens `path` for writing; InputError naming it if it cannot (as history.csv's writer).
std::unique_ptr<std::FILE, FileCloser> Open(const std::string& path) {
  std::unique_ptr<std::FILE, FileCloser> f(std::fopen(path.c_str(), "w"));
  if (!f) throw InputError("visual output: cannot write " + path);
  return f;
}

void Close(std::unique_ptr<std::FILE, FileCloser> f, const std::string& path) {
  const bool failed = std::ferror(f.get()) != 0;
  if (std::fclose(f.release()) != 0 || failed) throw InputError("visual output: writing " + path + " failed");
}

void IntArray(std::FILE* f, const char* name, const std::vector<int>& values, const char* type = "Int32") {
  std::fprintf(f, "        <DataArray type=\"%s\" Name=\"%s\" format=\"ascii\">\n         ", type, name);
  for (size_t i = 0; i < values.size(); ++i) std::fprintf(f, "%s%d", (i % 16 == 15) ? "\n         " : " ", values[i]);
  std::fprintf(f, "\n        </DataArray>\n");
}

void Vectors(std::FILE* f, const char* name, const std::vector<Eigen::Vector3d>& values) {
  std::fprintf(f, "        <DataArray type=\"Float64\" Name=\"%s\" NumberOfComponents=\"3\" format=\"ascii\">\n", name);
  for (const auto& v : values) std::fprintf(f, "          %.17g %.17g %.17g\n", v.x(), v.y(), v.z());
  std::fprintf(f, "        </DataArray>\n");
}

}  // namespace

int VisualFrame::AddPoint(const Eigen::Vector3d& x, const Eigen::Vector3d& displacement) {
  x_.push_back(x);
  displacement_.push_back(displacement);
  return static_cast<int>(x_.size()) - 1;
}

void VisualFrame::AddCell(int vtk_type, const std::vector<int>& points, Kind kind, int entity, int in_contact,
                          double von_mises) {
  connectivity_.insert(connectivity_.end(), points.begin(), points.end());
  offsets_.push_back(static_cast<int>(connectivity_.size()));
  type_.push_back(vtk_type);
  kind_.push_back(static_cast<int>(kind));
  entity_.push_back(entity);
  in_contact_.push_back(in_contact);
  von_mises_.push_back(von_mises);
}

void VisualFrame::AddSquare(const Eigen::Vector3d& centre, const Eigen::Vector3d& t1, const Eigen::Vector3d& t2,
                            double half, Kind kind, int entity, int in_contact) {
  const int first = points();
  for (const auto& [a, b] : {std::pair{-1, -1}, std::pair{1, -1}, std::pair{1, 1}, std::pair{-1, 1}}) {
    AddPoint(centre + half * (a * t1 + b * t2));
  }
  AddCell(kQuad, {first, first + 1, first + 2, first + 3}, kind, entity, in_contact);
}

void VisualFrame::Name(Kind kind, int entity, const std::string& name) {
  legend_.push_back(std::to_string(static_cast<int>(kind)) + "," + std::to_string(entity) + "," + name);
}

void VisualFrame::WriteVtu(const std::string& path, double time) const {
  auto f = Open(path);
  std::fprintf(f.get(), "<?xml version=\"1.0\"?>\n");
  std::fprintf(f.get(), "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\">\n");
  std::fprintf(f.get(), "  <UnstructuredGrid>\n");
  // The time as field data, so that a single file says when it is (ParaView's TimeValue).
  std::fprintf(f.get(), "    <FieldData>\n      <DataArray type=\"Float64\" Name=\"TimeValue\" NumberOfTuples=\"1\" "
                        "format=\"ascii\">%.17g</DataArray>\n    </FieldData>\n", time);
  std::fprintf(f.get(), "    <Piece NumberOfPoints=\"%d\" NumberOfCells=\"%d\">\n", points(), cells());
  std::fprintf(f.get(), "      <Points>\n");
  Vectors(f.get(), "Points", x_);
  std::fprintf(f.get(), "      </Points>\n      <Cells>\n");
  IntArray(f.get(), "connectivity", connectivity_);
  IntArray(f.get(), "offsets", offsets_);
  IntArray(f.get(), "types", type_, "UInt8");
  std::fprintf(f.get(), "      </Cells>\n");
  std::fprintf(f.get(), "      <PointData Vectors=\"displacement\">\n");
  Vectors(f.get(), "displacement", displacement_);
  std::fprintf(f.get(), "      </PointData>\n      <CellData Scalars=\"kind\">\n");
  IntArray(f.get(), "kind", kind_);
  IntArray(f.get(), "entity", entity_);
  IntArray(f.get(), "in_contact", in_contact_);
  std::fprintf(f.get(), "        <DataArray type=\"Float64\" Name=\"von_mises\" format=\"ascii\">\n");
  for (double s : von_mises_) std::fprintf(f.get(), "          %.9g\n", s);
  std::fprintf(f.get(), "        </DataArray>\n      </CellData>\n    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n");
  Close(std::move(f), path);
}

VisualSeries::VisualSeries(std::string folder) : folder_(std::move(folder)) {
  std::error_code ec;
  std::filesystem::create_directories(folder_ + "/visual", ec);
  if (ec) throw InputError("visual output: cannot create " + folder_ + "/visual: " + ec.message());
}

void VisualSeries::Write(const VisualFrame& frame, double time) {
  char name[32];
  std::snprintf(name, sizeof name, "visual/%06d.vtu", frames());
  frame.WriteVtu(folder_ + "/" + name, time);
  if (frames() == 0) {
    auto legend = Open(folder_ + "/visual/legend.csv");
    std::fprintf(legend.get(), "kind,entity,name\n");
    for (const auto& row : frame.legend()) std::fprintf(legend.get(), "%s\n", row.c_str());
    Close(std::move(legend), folder_ + "/visual/legend.csv");
  }
  times_.push_back(time);
  files_.emplace_back(name);
  // The index rewritten whole (a few thousand lines at most), through a temporary file and a
  // rename: a run stopped at any moment leaves a complete index of the frames written.
  const std::string index = folder_ + "/visual.pvd", temporary = index + ".tmp";
  auto f = Open(temporary);
  std::fprintf(f.get(), "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"1.0\">\n  <Collection>\n");
  for (size_t i = 0; i < times_.size(); ++i) {
    std::fprintf(f.get(), "    <DataSet timestep=\"%.17g\" part=\"0\" file=\"%s\"/>\n", times_[i], files_[i].c_str());
  }
  std::fprintf(f.get(), "  </Collection>\n</VTKFile>\n");
  Close(std::move(f), temporary);
  std::error_code ec;
  std::filesystem::rename(temporary, index, ec);
  if (ec) throw InputError("visual output: cannot rename " + temporary + ": " + ec.message());
}

std::vector<std::pair<double, std::string>> ReadPvd(const std::string& path) {
  std::vector<std::pair<double, std::string>> entries;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    const auto t = line.find("timestep=\""), file = line.find("file=\"");
    if (t == std::string::npos || file == std::string::npos) continue;
    const auto t_end = line.find('"', t + 10), file_end = line.find('"', file + 6);
    if (t_end == std::string::npos || file_end == std::string::npos) continue;
    entries.emplace_back(std::stod(line.substr(t + 10, t_end - t - 10)), line.substr(file + 6, file_end - file - 6));
  }
  return entries;
}

void WriteScenePvd(const std::string& path, const std::vector<std::pair<std::string, std::string>>& series) {
  auto f = Open(path);
  std::fprintf(f.get(), "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"1.0\">\n  <Collection>\n");
  for (size_t part = 0; part < series.size(); ++part) {
    const auto& [prefix, pvd] = series[part];
    for (const auto& [time, file] : ReadPvd(pvd)) {
      std::fprintf(f.get(), "    <DataSet timestep=\"%.17g\" part=\"%zu\" name=\"%s\" file=\"%s%s\"/>\n", time, part,
                   prefix.empty() ? "smooth" : prefix.substr(0, prefix.size() - 1).c_str(), prefix.c_str(),
                   file.c_str());
    }
  }
  std::fprintf(f.get(), "  </Collection>\n</VTKFile>\n");
  Close(std::move(f), path);
}

}  // namespace cosim::interface
