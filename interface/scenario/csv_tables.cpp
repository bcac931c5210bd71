#include "interface/scenario/csv_tables.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <vector>

#include "interface/base/input_file.h"
#include "interface/scenario/checks.h"
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

std::vector<std::string> SplitCells(const std::string& line) {
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

// A column name as a header holds one: a letter or '_', then letters, digits, '_', '.', '-'
// (at most 64 of them).
bool LooksLikeAName(const std::string& cell) {
  if (cell.empty() || cell.size() > 64) return false;
  if (!std::isalpha(static_cast<unsigned char>(cell[0])) && cell[0] != '_') return false;
  return std::all_of(cell.begin(), cell.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' || c == '-';
  });
}
bool LooksLikeAHeader(const std::vector<std::string>& cells) {
  return std::all_of(cells.begin(), cells.end(), LooksLikeAName);
}

// A number from a CSV cell, or nothing.
bool ReadNumber(const std::string& cell, double* value) {
  char* end = nullptr;
  errno = 0;
  *value = std::strtod(cell.c_str(), &end);
  // (the whole cell: "0.5\0…" was read as 0.5)
  return end != cell.c_str() && end == cell.c_str() + cell.size() && errno != ERANGE && std::isfinite(*value);
}

using Fail = std::function<void(const std::string&, const std::string&)>;
// Names the file, the line being read and (if not empty) a column, for a message.
using Where = std::function<std::string(const std::string&)>;
using Cells = std::vector<std::string>;

// Streams the CSV file `file` named by the field at `place`: blank lines and lines starting with
// '#' skipped, the first other line the header (`on_header`), every later one a row of as many
// cells (`on_row`). Returns the number of rows, −1 without a header.
int ReadCsv(const std::filesystem::path& file, const std::string& place, const std::string& expected, const Fail& fail,
            const std::function<void(const Cells&, const Where&)>& on_header,
            const std::function<void(const Cells&, const Where&)>& on_row) {
  // (A FIFO, a device or an endless file is refused before it is read: InputFile.)
  const InputFile text = ReadInputFile(file, kMaxTableBytes);
  if (!text.ok()) {
    fail(place, text.why + "; expected " + expected + " (relative paths are from the scenario file's folder)");
  }
  std::istringstream in(text.text);
  int number = 0, rows = -1;
  size_t columns = 0;
  const Where where = [&](const std::string& column) {
    return "'" + file.string() + "' line " + std::to_string(number) +
           (column.empty() ? "" : ", column '" + column + "'");
  };
  std::string line;
  while (std::getline(in, line)) {
    ++number;
    const std::string trimmed = Trim(line);
    if (trimmed.empty() || trimmed[0] == '#') continue;
    const Cells cells = SplitCells(line);
    if (rows < 0) {
      on_header(cells, where);
      columns = cells.size();
      rows = 0;
      continue;
    }
    if (cells.size() != columns) {
      fail(place, where("") + ": " + std::to_string(cells.size()) + " cells; the header has " +
                      std::to_string(columns) + " columns");
    }
    on_row(cells, where);
    ++rows;
  }
  return rows;
}

// Reads one file (m's field `file_field`) into `stations` (a repeated message field of `m`),
// one message per row, the header naming its fields; `path` is m's field path.
void Load(pb::Message* m, const pb::FieldDescriptor* file_field, const pb::FieldDescriptor* stations,
          const std::string& path, const std::function<std::filesystem::path(const std::string&)>& resolve,
          const Fail& fail) {
  const pb::Reflection* r = m->GetReflection();
  const std::string place = path + "." + file_field->name();
  if (r->FieldSize(*m, stations) > 0)
    fail(place, "given with " + stations->name() + " too; give the table in one of them");
  const std::filesystem::path file = resolve(r->GetString(*m, file_field));
  const pb::Descriptor* station = stations->message_type();
  std::vector<const pb::FieldDescriptor*> columns;
  auto header = [&](const Cells& cells, const Where& where) {
    for (const std::string& name : cells) {
      const pb::FieldDescriptor* f = station->FindFieldByName(name);
      if (f == nullptr || f->is_repeated() || f->cpp_type() == pb::FieldDescriptor::CPPTYPE_MESSAGE) {
        // (A name is quoted; other text is not: a file that is no table, /etc/shadow, had its
        // first line echoed into the terminal and summary.json.)
        fail(place, where("") + ": " +
                        (LooksLikeAName(name) ? "'" + name + "' is not a field of " + station->name()
                                              : "the first line is not a header of " + station->name() +
                                                    "'s fields (is it a CSV table?)") +
                        "; expected a header of " + Known(station));
      }
      for (const pb::FieldDescriptor* seen : columns) {
        if (seen == f) fail(place, where("") + ": column '" + EchoedText(name) + "' is given twice");
      }
      columns.push_back(f);
    }
  };
  auto row = [&](const Cells& cells, const Where& where) {
    pb::Message* s = r->AddMessage(m, stations);
    const pb::Reflection* sr = s->GetReflection();
    for (size_t c = 0; c < columns.size(); ++c) {
      const pb::FieldDescriptor* f = columns[c];
      if (cells[c].empty()) continue;
      if (f->cpp_type() == pb::FieldDescriptor::CPPTYPE_STRING) {
        sr->SetString(s, f, cells[c]);
        continue;
      }
      double v = 0.0;
      const bool whole =
          f->cpp_type() != pb::FieldDescriptor::CPPTYPE_DOUBLE && f->cpp_type() != pb::FieldDescriptor::CPPTYPE_FLOAT;
      if (!ReadNumber(cells[c], &v) || (whole && v != std::floor(v))) {
        fail(place, where(f->name()) + ": '" + EchoedText(cells[c]) + "' is not " +
                        (whole ? "a whole number" : "a finite number"));
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
  };
  if (ReadCsv(file, place, "a CSV file of " + stations->name(), fail, header, row) <= 0)
    fail(place, "'" + file.string() + "' holds no " + stations->name() + "; expected a header line and one row each");
  r->ClearField(m, file_field);
}

// A TimeFunction table's `file`: its time and value columns into `time` and `value`.
void LoadColumns(scenario::TimeFunction::Table* table, const std::string& path,
                 const std::function<std::filesystem::path(const std::string&)>& resolve, const Fail& fail) {
  const std::string place = path + ".file";
  if (table->time_size() > 0 || table->value_size() > 0)
    fail(place, "given with time or value too; give the table in one of them");
  if (!table->has_value_column())
    fail(path + ".value_column", "is missing; name the file's column that holds the values");
  const std::string time_name = table->has_time_column() ? table->time_column() : "time";
  const std::filesystem::path file = resolve(table->file());
  Cells names;
  size_t time_at = 0, value_at = 0;
  auto header = [&](const Cells& cells, const Where& where) {
    names = cells;
    std::string listed;
    bool has_time = false, has_value = false;
    for (size_t c = 0; c < cells.size(); ++c) {
      listed += (c == 0 ? "" : ", ") + cells[c];
      for (size_t d = 0; d < c; ++d) {
        if (cells[d] == cells[c]) fail(place, where("") + ": column '" + EchoedText(cells[c]) + "' is given twice");
      }
      if (cells[c] == time_name) {
        time_at = c;
        has_time = true;
      }
      if (cells[c] == table->value_column()) {
        value_at = c;
        has_value = true;
      }
    }
    // (The header listed only if it looks like one: a file that is no table is not quoted.)
    const std::string shown = LooksLikeAHeader(cells)
                                  ? "; the header has " + EchoedText(listed)
                                  : "; the first line is not a header of names (is it a CSV table?)";
    if (!has_time) fail(path + ".time_column", where("") + ": no column '" + EchoedText(time_name) + "'" + shown);
    if (!has_value) {
      fail(path + ".value_column", where("") + ": no column '" + EchoedText(table->value_column()) + "'" + shown);
    }
  };
  auto row = [&](const Cells& cells, const Where& where) {
    double t = 0.0, v = 0.0;
    for (auto [at, into] : {std::pair{time_at, &t}, std::pair{value_at, &v}}) {
      if (!ReadNumber(cells[at], into)) {
        fail(place, where(names[at]) + ": '" + EchoedText(cells[at]) + "' is not a finite number");
      }
    }
    const double scaled = v * table->value_scale();
    if (!std::isfinite(scaled)) {  // (accepted as inf before, or exit 3 when the run reached it)
      fail(place, where(names[value_at]) + ": " + EchoedText(cells[value_at]) + " times value_scale " +
                      FormatNumber(table->value_scale()) + " is not a finite number");
    }
    table->add_time(t);
    table->add_value(scaled);
  };
  if (ReadCsv(file, place, "a CSV file with a header line naming its columns", fail, header, row) <= 0)
    fail(place, "'" + file.string() + "' holds no rows; expected a header line and one row per time");
  table->clear_file();
}

void Walk(pb::Message* m, const std::string& path,
          const std::function<std::filesystem::path(const std::string&)>& resolve,
          const std::function<void(const std::string&, const std::string&)>& fail) {
  const pb::Reflection* r = m->GetReflection();
  for (auto [file_name, rows_name] : {std::pair{"stations_file", "stations"}, std::pair{"grid_file", "grid"}}) {
    const pb::FieldDescriptor* file_field = m->GetDescriptor()->FindFieldByName(file_name);
    const pb::FieldDescriptor* rows = m->GetDescriptor()->FindFieldByName(rows_name);
    if (file_field != nullptr && rows != nullptr && r->HasField(*m, file_field))
      Load(m, file_field, rows, path, resolve, fail);
  }
  if (m->GetDescriptor() == scenario::TimeFunction::Table::descriptor()) {
    auto* table = static_cast<scenario::TimeFunction::Table*>(m);
    if (table->has_file()) LoadColumns(table, path, resolve, fail);
  }
  ForEachChild(m, path, [&](pb::Message* child, const std::string& at) { Walk(child, at, resolve, fail); });
}

}  // namespace

void LoadCsvTables(scenario::Scenario* proto, const std::function<std::filesystem::path(const std::string&)>& resolve,
                   const std::function<void(const std::string&, const std::string&)>& fail) {
  Walk(proto, "", resolve, fail);
}

}  // namespace cosim::interface
