#include "interface/scenario/station_files.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <vector>

#include "interface/scenario/message_tree.h"

namespace cosim::interface {

namespace {

namespace pb = google::protobuf;

std::string Trim(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t\r\"");
  if (a == std::string::npos) return "";
  const size_t b = s.find_last_not_of(" \t\r\"");
  return s.substr(a, b - a + 1);
}

std::vector<std::string> Cells(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream in(line);
  std::string cell;
  while (std::getline(in, cell, ',')) cells.push_back(Trim(cell));
  if (!line.empty() && line.back() == ',') cells.push_back("");
  return cells;
}

std::string Known(const pb::Descriptor* d) {
  std::string names;
  for (int i = 0; i < d->field_count(); ++i) {
    const pb::FieldDescriptor* f = d->field(i);
    if (f->is_repeated() || f->cpp_type() == pb::FieldDescriptor::CPPTYPE_MESSAGE) continue;
    names += (names.empty() ? "" : ", ") + f->name();
  }
  return names;
}

// Reads one file into `stations` (a repeated message field of `m`); `path` is m's field path.
void Load(pb::Message* m, const pb::FieldDescriptor* stations, const std::string& path,
          const std::function<std::filesystem::path(const std::string&)>& resolve,
          const std::function<void(const std::string&, const std::string&)>& fail) {
  const pb::Reflection* r = m->GetReflection();
  const pb::FieldDescriptor* file_field = m->GetDescriptor()->FindFieldByName("stations_file");
  const std::string given = r->GetString(*m, file_field);
  const std::string place = path + ".stations_file";
  if (r->FieldSize(*m, stations) > 0) fail(place, "given with stations too; give the table in one of them");
  const std::filesystem::path file = resolve(given);
  std::ifstream in(file);
  if (!in)
    fail(place, "'" + file.string() +
                    "' cannot be read; expected a CSV file of stations (relative paths are "
                    "from the scenario file's folder)");
  const pb::Descriptor* station = stations->message_type();
  std::vector<const pb::FieldDescriptor*> columns;
  std::string line;
  int number = 0, rows = 0;
  auto where = [&](const std::string& column) {
    return "'" + file.string() + "' line " + std::to_string(number) +
           (column.empty() ? "" : ", column '" + column + "'");
  };
  while (std::getline(in, line)) {
    ++number;
    const std::string trimmed = Trim(line);
    if (trimmed.empty() || trimmed[0] == '#') continue;
    const std::vector<std::string> cells = Cells(line);
    if (columns.empty()) {
      for (const std::string& name : cells) {
        const pb::FieldDescriptor* f = station->FindFieldByName(name);
        if (f == nullptr || f->is_repeated() || f->cpp_type() == pb::FieldDescriptor::CPPTYPE_MESSAGE) {
          fail(place, where("") + ": '" + name + "' is not a field of " + station->name() + "; expected a header of " +
                          Known(station));
        }
        for (const pb::FieldDescriptor* seen : columns) {
          if (seen == f) fail(place, where("") + ": column '" + name + "' is given twice");
        }
        columns.push_back(f);
      }
      continue;
    }
    if (cells.size() != columns.size()) {
      fail(place, where("") + ": " + std::to_string(cells.size()) + " cells; the header has " +
                      std::to_string(columns.size()) + " columns");
    }
    pb::Message* s = r->AddMessage(m, stations);
    const pb::Reflection* sr = s->GetReflection();
    for (size_t c = 0; c < columns.size(); ++c) {
      const pb::FieldDescriptor* f = columns[c];
      if (cells[c].empty()) continue;
      if (f->cpp_type() == pb::FieldDescriptor::CPPTYPE_STRING) {
        sr->SetString(s, f, cells[c]);
        continue;
      }
      char* end = nullptr;
      errno = 0;
      const double v = std::strtod(cells[c].c_str(), &end);
      const bool whole =
          f->cpp_type() != pb::FieldDescriptor::CPPTYPE_DOUBLE && f->cpp_type() != pb::FieldDescriptor::CPPTYPE_FLOAT;
      if (end == cells[c].c_str() || *end != '\0' || errno == ERANGE || !std::isfinite(v) ||
          (whole && v != std::floor(v))) {
        fail(place, where(f->name()) + ": '" + cells[c] + "' is not " + (whole ? "a whole number" : "a finite number"));
      }
      switch (f->cpp_type()) {
        case pb::FieldDescriptor::CPPTYPE_DOUBLE:
          sr->SetDouble(s, f, v);
          break;
        case pb::FieldDescriptor::CPPTYPE_FLOAT:
          sr->SetFloat(s, f, static_cast<float>(v));
          break;
        case pb::FieldDescriptor::CPPTYPE_INT32:
          sr->SetInt32(s, f, static_cast<int32_t>(v));
          break;
        case pb::FieldDescriptor::CPPTYPE_INT64:
          sr->SetInt64(s, f, static_cast<int64_t>(v));
          break;
        default:
          fail(place, where(f->name()) + ": this column cannot be read from a CSV cell");
      }
    }
    ++rows;
  }
  if (columns.empty() || rows == 0)
    fail(place, "'" + file.string() + "' holds no stations; expected a header line and one row per station");
  r->ClearField(m, file_field);
}

void Walk(pb::Message* m, const std::string& path,
          const std::function<std::filesystem::path(const std::string&)>& resolve,
          const std::function<void(const std::string&, const std::string&)>& fail) {
  const pb::Reflection* r = m->GetReflection();
  const pb::FieldDescriptor* file_field = m->GetDescriptor()->FindFieldByName("stations_file");
  const pb::FieldDescriptor* stations = m->GetDescriptor()->FindFieldByName("stations");
  if (file_field != nullptr && stations != nullptr && r->HasField(*m, file_field))
    Load(m, stations, path, resolve, fail);
  ForEachChild(m, path, [&](pb::Message* child, const std::string& at) { Walk(child, at, resolve, fail); });
}

}  // namespace

void LoadStationFiles(scenario::Scenario* proto,
                      const std::function<std::filesystem::path(const std::string&)>& resolve,
                      const std::function<void(const std::string&, const std::string&)>& fail) {
  Walk(proto, "", resolve, fail);
}

}  // namespace cosim::interface
