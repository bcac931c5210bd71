#include "interface/visual/visual_frame.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iomanip>
#include <memory>
#include <sstream>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "interface/base/errors.h"
#include "interface/base/folder_lock.h"
#include "interface/base/input_file.h"
#include "interface/base/whole_file.h"

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

// RFC 4648 base64 of `bytes` (with padding).
std::string Base64(const std::vector<char>& bytes) {
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (size_t i = 0; i < bytes.size(); i += 3) {
    const size_t n = std::min<size_t>(3, bytes.size() - i);
    std::uint32_t word = 0;
    for (size_t k = 0; k < 3; ++k) {
      word = (word << 8) | (k < n ? static_cast<unsigned char>(bytes[i + k]) : 0U);
    }
    for (size_t k = 0; k < 4; ++k) out += k <= n ? kAlphabet[(word >> (18 - 6 * k)) & 63U] : '=';
  }
  return out;
}

// The frame's arrays as VTK XML inline binary: each DataArray holds the base64 of a UInt64 byte
// count followed by the values in the machine's byte order, encoded as one stream (as VTK's own
// writer does). Every double exact, at 4/3 of the raw size (a Puma frame 42 kB against ~51 kB
// as 17-digit ASCII). Not appended raw data: Debian's meshio 5.0 re-encodes such a block array
// by array and finds each array again by its offset attribute, which it overwrites as it goes,
// so an array whose new offset equals a later one's old offset is read in its place (two
// contact nodes' frames: the connectivity read as the displacement, issue 50).
class Inline {
 public:
  // The DataArray element of `values` (`components` per tuple).
  template <typename T>
  static std::string Array(const char* type, const char* name, const T* values, size_t count, int components = 1) {
    const std::uint64_t size = count * sizeof(T);
    std::vector<char> bytes;
    bytes.reserve(sizeof size + size);
    const auto* head = reinterpret_cast<const char*>(&size);
    bytes.insert(bytes.end(), head, head + sizeof size);
    const auto* v = reinterpret_cast<const char*>(values);
    bytes.insert(bytes.end(), v, v + size);
    return std::string("        <DataArray type=\"") + type + "\" Name=\"" + name + "\"" +
           (components == 3 ? " NumberOfComponents=\"3\"" : "") + " format=\"binary\">" + Base64(bytes) +
           "</DataArray>\n";
  }
  static std::string Ints(const char* name, const std::vector<int>& values) {
    static_assert(sizeof(int) == 4);
    return Array("Int32", name, values.data(), values.size());
  }
  static std::string Vectors(const char* name, const std::vector<Eigen::Vector3d>& values) {
    std::vector<double> flat;
    flat.reserve(3 * values.size());
    for (const auto& x : values) flat.insert(flat.end(), {x.x(), x.y(), x.z()});
    return Array("Float64", name, flat.data(), values.size() * 3, 3);
  }
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
  using A = Inline;
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
  xml += "      <Points>\n" + A::Vectors("Points", x_) + "      </Points>\n      <Cells>\n";
  xml += A::Ints("connectivity", connectivity_) + A::Ints("offsets", offsets_) +
         A::Array("UInt8", "types", types.data(), types.size());
  xml += "      </Cells>\n      <PointData Vectors=\"displacement\">\n" + A::Vectors("displacement", displacement_);
  xml += "      </PointData>\n      <CellData Scalars=\"kind\">\n";
  xml += A::Ints("kind", kind_) + A::Ints("entity", entity_) + A::Ints("in_contact", in_contact_) +
         A::Array("Float64", "von_mises", von_mises_.data(), von_mises_.size());
  xml += "      </CellData>\n    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n";
  auto f = Open(path);
  std::fwrite(xml.data(), 1, xml.size(), f.get());
  Close(std::move(f), path);
}

VisualSeries::VisualSeries(std::string folder) : folder_(std::move(folder)) {
  std::error_code ec;
  std::filesystem::create_directories(folder_ + "/visual", ec);
  if (ec) throw InputError("visual output: cannot create " + folder_ + "/visual: " + ec.message());
  if (HeldByAnotherRun(folder_ + "/visual")) {  // (its frames would go into a running run's folder)
    throw InputError("visual output: " + folder_ +
                     "/visual, where this run's frames go, is the output folder of a running run; give this run "
                     "another --out");
  }
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
  // The index rewritten whole (a few thousand lines at most; WriteWholeFile): a run stopped at
  // any moment leaves a complete index of the frames written.
  const WrittenFile written = WriteWholeFile(folder_ + "/visual.pvd", [this](std::ostream& f) {
    f << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"1.0\">\n  <Collection>\n";
    f << std::setprecision(17);  // (%.17g)
    for (size_t i = 0; i < times_.size(); ++i) {
      f << "    <DataSet timestep=\"" << times_[i] << "\" part=\"0\" file=\"" << files_[i] << "\"/>\n";
    }
    f << "  </Collection>\n</VTKFile>\n";
  });
  if (!written.ok()) throw InputError("visual output: " + written.why);
}

std::vector<std::pair<double, std::string>> ReadPvd(const std::string& path) {
  // A process's own index, read back bounded (InputFile): a link to a device reads nothing.
  const InputFile text = ReadInputFile(path, kMaxOutputBytes);
  if (!text.ok())
    throw InputError("visual output: " + text.why + "; expected the visual.pvd a process of this run wrote");
  std::vector<std::pair<double, std::string>> entries;
  std::istringstream in(text.text);
  std::string line;
  while (std::getline(in, line)) {
    const auto t = line.find("timestep=\""), file = line.find("file=\"");
    if (t == std::string::npos || file == std::string::npos) continue;
    const auto t_end = line.find('"', t + 10), file_end = line.find('"', file + 6);
    if (t_end == std::string::npos || file_end == std::string::npos) continue;
    const std::string stamp = line.substr(t + 10, t_end - t - 10);
    char* end = nullptr;
    const double time = std::strtod(stamp.c_str(), &end);
    if (end == stamp.c_str() || !std::isfinite(time)) continue;  // (not a line this project wrote)
    entries.emplace_back(time, line.substr(file + 6, file_end - file - 6));
  }
  return entries;
}

void WriteScenePvd(const std::string& path, const std::vector<std::pair<std::string, std::string>>& series) {
  std::vector<std::vector<std::pair<double, std::string>>> frames;
  for (const auto& part : series) frames.push_back(ReadPvd(part.second));
  // Whole or not at all (WriteWholeFile): a full disk leaves no half index, and no temporary.
  const WrittenFile written = WriteWholeFile(path, [&series, &frames](std::ostream& f) {
    f << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"1.0\">\n  <Collection>\n";
    f << std::setprecision(17);  // (%.17g)
    for (size_t part = 0; part < series.size(); ++part) {
      const std::string& prefix = series[part].first;
      const std::string name = prefix.empty() ? "smooth" : prefix.substr(0, prefix.size() - 1);
      for (const auto& [time, file] : frames[part]) {
        f << "    <DataSet timestep=\"" << time << "\" part=\"" << part << "\" name=\"" << name << "\" file=\""
          << prefix << file << "\"/>\n";
      }
    }
    f << "  </Collection>\n</VTKFile>\n";
  });
  if (!written.ok()) throw InputError("visual output: " + written.why);
}

}  // namespace cosim::interface
