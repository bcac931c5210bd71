#include "interface/visual/visual_frame.h"

#include <bit>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "interface/run/errors.h"

namespace cosim::interface {

namespace {

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};

// Opens `path` for writing; InputError naming it if it cannot (as history.csv's writer).
std::unique_ptr<std::FILE, FileCloser> Open(const std::string& path) {
  std::unique_ptr<std::FILE, FileCloser> f(std::fopen(path.c_str(), "wb"));
  if (!f) throw InputError("visual output: cannot write " + path);
  return f;
}

void Close(std::unique_ptr<std::FILE, FileCloser> f, const std::string& path) {
  const bool failed = std::ferror(f.get()) != 0;
  if (std::fclose(f.release()) != 0 || failed) throw InputError("visual output: writing " + path + " failed");
}

// The frame's arrays as VTK XML "appended" raw binary: each DataArray element names its offset
// into one block written after the XML (a UInt64 byte count, then the values in the machine's
// byte order). Every double exact, and ~60 % of the 17-digit ASCII's size (a Puma frame: 32 kB
// against ~51 kB).
class Appended {
 public:
  // The DataArray element of `values` (`components` per tuple) and its bytes queued.
  template <typename T>
  std::string Array(const char* type, const char* name, const T* values, size_t count, int components = 1) {
    char head[256];
    std::snprintf(head, sizeof head,
                  "        <DataArray type=\"%s\" Name=\"%s\"%s format=\"appended\" offset=\"%zu\"/>\n", type, name,
                  components == 3 ? " NumberOfComponents=\"3\"" : "", bytes_.size());
    const std::uint64_t size = count * sizeof(T);
    const auto* p = reinterpret_cast<const char*>(&size);
    bytes_.insert(bytes_.end(), p, p + sizeof size);
    const auto* v = reinterpret_cast<const char*>(values);
    bytes_.insert(bytes_.end(), v, v + size);
    return head;
  }
  std::string Ints(const char* name, const std::vector<int>& values) {
    static_assert(sizeof(int) == 4);
    return Array("Int32", name, values.data(), values.size());
  }
  std::string Vectors(const char* name, const std::vector<Eigen::Vector3d>& values) {
    std::vector<double> flat;
    flat.reserve(3 * values.size());
    for (const auto& x : values) flat.insert(flat.end(), {x.x(), x.y(), x.z()});
    return Array("Float64", name, flat.data(), values.size() * 3, 3);
  }
  const std::vector<char>& bytes() const { return bytes_; }

 private:
  std::vector<char> bytes_;
};

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
  Appended data;
  std::vector<std::uint8_t> types(type_.begin(), type_.end());
  std::string xml;
  xml += std::string("<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"") +
         (std::endian::native == std::endian::little ? "LittleEndian" : "BigEndian") + "\" header_type=\"UInt64\">\n";
  xml += "  <UnstructuredGrid>\n";
  // The time as field data, so that a single file says when it is (ParaView's TimeValue).
  char line[256];
  std::snprintf(line, sizeof line,
                "    <FieldData>\n      <DataArray type=\"Float64\" Name=\"TimeValue\" NumberOfTuples=\"1\" "
                "format=\"ascii\">%.17g</DataArray>\n    </FieldData>\n",
                time);
  xml += line;
  std::snprintf(line, sizeof line, "    <Piece NumberOfPoints=\"%d\" NumberOfCells=\"%d\">\n", points(), cells());
  xml += line;
  xml += "      <Points>\n" + data.Vectors("Points", x_) + "      </Points>\n      <Cells>\n";
  xml += data.Ints("connectivity", connectivity_) + data.Ints("offsets", offsets_) +
         data.Array("UInt8", "types", types.data(), types.size());
  xml += "      </Cells>\n      <PointData Vectors=\"displacement\">\n" + data.Vectors("displacement", displacement_);
  xml += "      </PointData>\n      <CellData Scalars=\"kind\">\n";
  xml += data.Ints("kind", kind_) + data.Ints("entity", entity_) + data.Ints("in_contact", in_contact_) +
         data.Array("Float64", "von_mises", von_mises_.data(), von_mises_.size());
  xml += "      </CellData>\n    </Piece>\n  </UnstructuredGrid>\n  <AppendedData encoding=\"raw\">\n   _";
  auto f = Open(path);
  std::fwrite(xml.data(), 1, xml.size(), f.get());
  std::fwrite(data.bytes().data(), 1, data.bytes().size(), f.get());
  std::fputs("\n  </AppendedData>\n</VTKFile>\n", f.get());
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
