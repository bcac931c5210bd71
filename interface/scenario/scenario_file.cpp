#include "interface/scenario/scenario_file.h"

#include <google/protobuf/io/tokenizer.h>
#include <google/protobuf/text_format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <optional>
#include <sstream>

#include "interface/base/errors.h"
#include "interface/base/input_file.h"
#include "interface/scenario/checks.h"
#include "interface/scenario/csv_tables.h"
#include "interface/scenario/expression.h"

namespace cosim::interface {

namespace pb = google::protobuf;

namespace {

// Collects the first parse error with its (1-based) line and column.
class FirstErrorCollector : public pb::io::ErrorCollector {
 public:
  void AddError(int line, pb::io::ColumnNumber column, const std::string& message) override {
    if (!has_error_) {
      has_error_ = true;
      line_ = line;
      column_ = column;
      message_ = message;
    }
  }
  void AddWarning(int, pb::io::ColumnNumber, const std::string&) override {}

  bool has_error() const { return has_error_; }
  int line() const { return line_; }      // 0-based, or −1
  int column() const { return column_; }  // 0-based
  const std::string& message() const { return message_; }
  // "file:line:col: message" (line and column are 0-based in protobuf).
  std::string Format(const std::string& file) const {
    std::ostringstream out;
    if (line_ >= 0) {
      out << file << ":" << line_ + 1 << ":" << column_ + 1 << ": " << message_;
    } else {
      out << file << ": " << message_;
    }
    return out.str();
  }

 private:
  bool has_error_ = false;
  int line_ = -1;
  int column_ = -1;
  std::string message_;
};

// A `${EXPRESSION}` of the scenario text: [begin, end) in the text, the expression, and its
// 1-based line and column.
struct Placeholder {
  size_t begin = 0, end = 0;
  std::string expression;
  int line = 0, column = 0;
};

// The `${…}` of `text` outside comments (inside strings too). An unclosed one is an InputError
// placed by `place(line, column)` (both 1-based).
std::vector<Placeholder> FindPlaceholders(const std::string& text, const std::function<std::string(int, int)>& place) {
  std::vector<Placeholder> found;
  int line = 1;
  size_t line_start = 0;
  char quote = 0;  // the open string's quote, or 0
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n') {
      ++line;
      line_start = i + 1;
      quote = 0;  // protobuf strings do not span lines
      continue;
    }
    if (quote != 0) {
      if (c == '\\') {
        ++i;
      } else if (c == quote) {
        quote = 0;
      }
    } else if (c == '#') {
      while (i + 1 < text.size() && text[i + 1] != '\n') ++i;
      continue;
    } else if (c == '"' || c == '\'') {
      quote = c;
      continue;
    }
    if (c != '$' || i + 1 >= text.size() || text[i + 1] != '{') continue;
    const size_t close = text.find_first_of("}\n", i + 2);
    const int column = static_cast<int>(i - line_start) + 1;
    if (close == std::string::npos || text[close] != '}') {
      throw InputError(place(line, column) + ": '${' without its '}' on the same line; write ${NAME} or ${EXPRESSION}");
    }
    found.push_back({i, close + 1, text.substr(i + 2, close - i - 2), line, column});
    i = close;
  }
  return found;
}

// A scenario file's text: a regular file of at most ScenarioFile::kMaxScenarioBytes (a FIFO would
// block in open(), /dev/zero would be read until memory runs out). `where` names the place
// that asked for it in errors (the command line's path, or an include's file:line).
std::string ReadScenarioText(const std::string& path, const std::string& where) {
  const std::string what = where == path ? "the scenario file" : "the included file '" + path + "'";
  InputFile f = ReadInputFile(path, ScenarioFile::kMaxScenarioBytes);
  switch (f.problem) {
    case InputFile::Problem::kNone:
      break;
    case InputFile::Problem::kCannotRead:
      throw InputError(where + ": cannot read " + what + ": " + f.detail + " (does it exist and is it readable?)");
    case InputFile::Problem::kNotRegular:
      throw InputError(where + ": " + (where == path ? std::string("the scenario") : what) +
                       " is not a regular file (" + f.detail + "); expected a protobuf text file");
    case InputFile::Problem::kTooLarge:
      throw InputError(where + ": " + what + " has " + std::to_string(f.size) + " bytes; at most " +
                       std::to_string(ScenarioFile::kMaxScenarioBytes) +
                       " are read (tables belong in files of their own)");
  }
  return std::move(f.text);
}

// "file:line:col" of a line (1-based) of the expanded text: the file and line it came from.
std::string PlaceOf(const std::vector<std::pair<std::string, int>>& origins, const std::string& file, int line,
                    int column) {
  if (line >= 1 && static_cast<size_t>(line) <= origins.size()) {
    const auto& [from, at] = origins[static_cast<size_t>(line - 1)];
    return from + ":" + std::to_string(at) + ":" + std::to_string(column);
  }
  return file + ":" + std::to_string(line) + ":" + std::to_string(column);
}

// `include: "FILE"` (whitespace around each part, a comment after) as the whole line: FILE.
std::optional<std::string> IncludeOf(const std::string& line) {
  size_t i = 0;
  auto skip = [&] {
    while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
  };
  auto eat = [&](const std::string& token) {
    skip();
    if (line.compare(i, token.size(), token) != 0) return false;
    i += token.size();
    return true;
  };
  if (!eat("include") || !eat(":") || !eat("\"")) return std::nullopt;
  const size_t close = line.find('"', i);
  if (close == std::string::npos) return std::nullopt;
  const std::string file = line.substr(i, close - i);
  i = close + 1;
  skip();
  if (i < line.size() && line[i] != '#') return std::nullopt;
  return file;
}

// `include: "FILE"` alone on its line (a comment may follow): FILE's lines in its place, FILE
// relative to the folder of the file that includes it. `open` is the chain of files being
// included (a file that includes itself, directly or not, is refused), at most 16 deep;
// `included_at` the include line that brought `file` in (empty for the scenario itself). The
// expanded text is bounded as a scenario file is: nine 30-byte files each including the next ten
// times made 10⁹ lines, read until memory ran out.
// `read` holds the files read so far (a file included again is not read again).
void ExpandIncludes(const std::string& text, const std::string& file, const std::string& included_at,
                    std::vector<std::string>* open, std::map<std::string, std::string>* read, std::string* out,
                    std::vector<std::pair<std::string, int>>* origins) {
  std::stringstream in(text);
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    const std::optional<std::string> included = IncludeOf(line);
    if (!included) {
      out->append(line).push_back('\n');
      origins->emplace_back(file, n);
      if (static_cast<long long>(out->size()) > ScenarioFile::kMaxScenarioBytes) {
        throw InputError((included_at.empty() ? file + ":" + std::to_string(n) : included_at) +
                         ": the scenario's text with its includes passes " +
                         std::to_string(ScenarioFile::kMaxScenarioBytes) + " bytes here (" +
                         std::to_string(origins->size()) +
                         " lines so far); at most that is read: is a file included more often than meant?");
      }
      continue;
    }
    const std::string where = file + ":" + std::to_string(n);
    std::filesystem::path target(*included);
    if (target.empty()) throw InputError(where + ": include: an empty file name; expected include: \"FILE\"");
    if (target.is_relative()) target = std::filesystem::path(file).parent_path() / target;
    const std::string name = target.lexically_normal().string();
    if (std::find(open->begin(), open->end(), name) != open->end()) {
      throw InputError(where + ": include: '" + name + "' is already being included (a cycle)");
    }
    if (open->size() >= 16) throw InputError(where + ": include: more than 16 files deep");
    open->push_back(name);
    auto known = read->find(name);
    if (known == read->end()) known = read->emplace(name, ReadScenarioText(name, where + ": include")).first;
    ExpandIncludes(known->second, name, where, open, read, out, origins);
    open->pop_back();
  }
}

std::string FormatParameter(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.17g", v);
  return buffer;
}

// `path` is `prefix` or a field or element under it ("a.b" under "a", "a[2]" under "a", not
// "ab" nor "a[20]" under "a[2]").
bool Within(const std::string& path, const std::string& prefix) {
  return path.compare(0, prefix.size(), prefix) == 0 &&
         (path.size() == prefix.size() || path[prefix.size()] == '.' || path[prefix.size()] == '[');
}

bool IsIdentifier(const std::string& name) {
  if (name.empty() || std::isdigit(static_cast<unsigned char>(name[0]))) return false;
  return std::all_of(name.begin(), name.end(),
                     [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; });
}

std::string KnownFields(const pb::Descriptor* descriptor) {
  std::string names;
  for (int i = 0; i < descriptor->field_count(); ++i) {
    if (i > 0) names += ", ";
    names += descriptor->field(i)->name();
  }
  return names;
}

bool IsDecimal(const std::string& s) {
  if (s.empty()) return false;
  for (char c : s) {
    if (!std::isdigit(static_cast<unsigned char>(c))) return false;
  }
  return true;
}

// A decimal index, or -1 when it does not fit an int (no list is that long).
int ParseIndex(const std::string& key) {
  int index = -1;
  const auto [end, error] = std::from_chars(key.data(), key.data() + key.size(), index);
  return error == std::errc() && end == key.data() + key.size() ? index : -1;
}

// Resolves the key of a repeated field to an index: a decimal index, or the element whose
// `name` field equals the key. Returns -1 when no element matches.
int ResolveIndex(const pb::Message& parent, const pb::FieldDescriptor* field, const std::string& key) {
  const pb::Reflection* reflection = parent.GetReflection();
  const int size = reflection->FieldSize(parent, field);
  if (IsDecimal(key)) {
    const int index = ParseIndex(key);
    return index >= 0 && index < size ? index : -1;
  }
  if (field->cpp_type() != pb::FieldDescriptor::CPPTYPE_MESSAGE) return -1;
  const pb::FieldDescriptor* name_field = field->message_type()->FindFieldByName("name");
  if (name_field == nullptr || name_field->type() != pb::FieldDescriptor::TYPE_STRING) return -1;
  for (int i = 0; i < size; ++i) {
    const pb::Message& element = reflection->GetRepeatedMessage(parent, field, i);
    if (element.GetReflection()->GetString(element, name_field) == key) return i;
  }
  return -1;
}

}  // namespace

std::vector<PathSegment> ParseFieldPath(const std::string& path, const std::string& context) {
  std::vector<PathSegment> segments;
  size_t pos = 0;
  auto bad = [&](const std::string& why) -> InputError {
    return InputError(context + ": malformed field path '" + path + "': " + why +
                      " (expected e.g. numerics.step or model.contact_nodes[0].mass)");
  };
  while (pos <= path.size()) {
    PathSegment segment;
    const size_t end = path.find_first_of(".[", pos);
    segment.field = path.substr(pos, end == std::string::npos ? std::string::npos : end - pos);
    if (segment.field.empty()) throw bad("empty field name at character " + std::to_string(pos + 1));
    for (char c : segment.field) {
      if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') {
        throw bad("invalid character '" + std::string(1, c) + "' in field name '" + segment.field + "'");
      }
    }
    pos = end;
    if (pos != std::string::npos && path[pos] == '[') {
      const size_t close = path.find(']', pos);
      if (close == std::string::npos) throw bad("'[' without ']'");
      segment.key = path.substr(pos + 1, close - pos - 1);
      if (segment.key.empty()) throw bad("empty index '[]'");
      segment.has_key = true;
      pos = close + 1;
    }
    segments.push_back(segment);
    if (pos == std::string::npos || pos == path.size()) break;
    if (path[pos] != '.') throw bad("expected '.' after ']'");
    ++pos;
  }
  return segments;
}

ScenarioFile::ScenarioFile() : tree_(std::make_unique<pb::TextFormat::ParseInfoTree>()) {}
ScenarioFile::ScenarioFile(ScenarioFile&&) noexcept = default;
ScenarioFile& ScenarioFile::operator=(ScenarioFile&&) noexcept = default;
ScenarioFile::~ScenarioFile() = default;

ScenarioFile ScenarioFile::Load(const std::string& path, const std::vector<std::string>& overrides, ScenarioView view) {
  return Parse(ReadScenarioText(path, path), path, overrides, view);
}

std::string ScenarioFile::Place(int line, int column) const { return PlaceOf(line_origins_, path_, line, column); }

void ScenarioFile::ParseText(const std::string& text) {
  FirstErrorCollector errors;
  pb::TextFormat::Parser parser;
  parser.RecordErrorsTo(&errors);
  parser.WriteLocationsTo(tree_.get());
  if (!parser.ParseFromString(text, &proto_) || errors.has_error()) {
    const std::string where = errors.line() >= 0 ? Place(errors.line() + 1, errors.column() + 1) : path_;
    // An include that did not stand on a line of its own reached the parser as a field.
    if (errors.message().find("has no field named \"include\"") != std::string::npos) {
      throw InputError(where +
                       ": `include: \"FILE\"` is read only on a line of its own (the file's lines replace that "
                       "line before the scenario is parsed); put it on its own line inside the block, e.g. "
                       "`each {` / `include: \"blade.pbtxt\"` / `}` on three lines");
    }
    throw InputError(where + ": " + errors.message() +
                     " (scenario files are protobuf text format; schema: proto/scenario.proto)");
  }
}

std::optional<double> ScenarioFile::ParameterValues::Find(const std::string& name) const {
  const auto v = values.find(name);
  return v == values.end() ? std::nullopt : std::optional<double>(v->second);
}

ScenarioFile::ParameterValues ScenarioFile::EvaluateParameters() const {
  ParameterValues out;
  const NameLookup lookup = [&out](const std::string& name) { return out.Find(name); };
  for (int i = 0; i < proto_.parameters_size(); ++i) {
    const scenario::Parameter& p = proto_.parameters(i);
    const std::string path = "parameters[" + std::to_string(i) + "]";
    if (!IsIdentifier(p.name()) || p.name() == "pi") {
      Fail(path + ".name", "'" + p.name() +
                               "' is not a parameter name; expected letters, digits and _, not starting "
                               "with a digit, and not 'pi'");
    }
    if (out.values.count(p.name()) != 0) Fail(path + ".name", "'" + p.name() + "' is defined twice");
    double v = 0.0;
    switch (p.definition_case()) {
      case scenario::Parameter::kValue:
        v = p.value();
        break;
      case scenario::Parameter::kExpression:
        v = EvaluateExpression(p.expression(), lookup, Where(path + ".expression") + ": " + path + ".expression",
                               out.names.empty() ? "none is defined before it" : "defined before it: " + out.names);
        break;
      default:
        Fail(path, "'" + p.name() + "' has neither a value nor an expression");
    }
    if (!std::isfinite(v)) Fail(path + ".value", "is " + FormatParameter(v) + "; expected a finite number");
    out.values[p.name()] = v;
    out.names += (out.names.empty() ? "" : ", ") + p.name();
  }
  return out;
}

std::string ScenarioFile::ExpandParameters(const std::string& joined,
                                           const std::vector<std::pair<std::string, int>>& origins,
                                           const std::string& display_name, const std::vector<std::string>& overrides,
                                           ParameterValues* parameters) {
  const auto place_of = [&origins, &display_name](int line, int column) {
    return PlaceOf(origins, display_name, line, column);
  };
  const std::vector<Placeholder> places = FindPlaceholders(joined, place_of);
  if (places.empty()) return joined;
  std::string blanked = joined;
  for (const Placeholder& p : places) {
    blanked.replace(p.begin, p.end - p.begin, "0" + std::string(p.end - p.begin - 1, ' '));
  }
  ScenarioFile first;
  first.path_ = display_name;
  first.line_origins_ = origins;
  first.ParseText(blanked);
  for (const std::string& argument : overrides) {
    if (argument.rfind("parameters", 0) == 0) first.ApplyOverride(argument);
  }
  *parameters = first.EvaluateParameters();
  const NameLookup lookup = [parameters](const std::string& name) { return parameters->Find(name); };
  const std::string known = parameters->names.empty() ? "the scenario defines none" : "defined: " + parameters->names;
  std::string expanded;
  size_t copied = 0;
  for (const Placeholder& p : places) {
    const std::string where = place_of(p.line, p.column) + ": ${" + EchoedText(p.expression) + "}";
    expanded += joined.substr(copied, p.begin - copied) +
                FormatParameter(EvaluateExpression(p.expression, lookup, where, known));
    copied = p.end;
  }
  return expanded + joined.substr(copied);
}

ScenarioFile ScenarioFile::Parse(const std::string& text, const std::string& display_name,
                                 const std::vector<std::string>& overrides, ScenarioView view) {
  // Included files first: their lines in place of each `include: "FILE"` line, every line
  // remembering the file and line it came from. Then the parameters' ${…}.
  std::string joined;
  std::vector<std::pair<std::string, int>> origins;
  std::vector<std::string> open{display_name};
  std::map<std::string, std::string> read;
  ExpandIncludes(text, display_name, "", &open, &read, &joined, &origins);
  ParameterValues substituted;
  const std::string expanded = ExpandParameters(joined, origins, display_name, overrides, &substituted);
  ScenarioFile file;
  file.path_ = display_name;
  file.line_origins_ = std::move(origins);
  file.ParseText(expanded);
  // Overrides of the patterns come before their expansion (a count, a template field), the
  // others after it, so that they can reach the copies too (the launcher sets each contact
  // process's endpoint, and a process may come from a pattern).
  auto of_patterns = [](const std::string& argument) { return argument.rfind("patterns", 0) == 0; };
  for (const std::string& argument : overrides) {
    if (of_patterns(argument)) file.ApplyOverride(argument);
  }
  // The patterns' numbers finite before they are copied (a template's rotation [nan, 0.1745, 0]
  // was turned into "no rotation" by the copying, and the check after it found nothing); the
  // rest of the scene is checked once, after the expansion.
  // A contact process's view: the smooth model reduced to names before it is copied
  // (contact_view.h); what it drops is the coordinator's to apply and check.
  const bool contact_view = view == ScenarioView::kContactProcess;
  if (contact_view) {
    if (file.proto_.has_model()) ReduceToContactView(file.proto_.mutable_model());
    for (scenario::Pattern& p : *file.proto_.mutable_patterns()) {
      if (p.has_each() && p.each().has_model()) ReduceToContactView(p.mutable_each()->mutable_model());
    }
  }
  for (int i = 0; i < file.proto_.patterns_size(); ++i) {
    file.CheckFinite(file.proto_.patterns(i), "patterns[" + std::to_string(i) + "]");
  }
  file.pattern_origins_ = ExpandPatterns(
      &file.proto_, [&file](const std::string& path, const std::string& message) { file.Fail(path, message); });
  for (const std::string& argument : overrides) {
    if (of_patterns(argument)) continue;
    if (contact_view) {
      const size_t eq = argument.find('=');
      if (eq != std::string::npos && eq > 0 &&
          OutsideContactView(ParseFieldPath(argument.substr(0, eq), "--set " + argument))) {
        continue;
      }
    }
    file.ApplyOverride(argument);
    file.NoteCopyOverride(argument);
  }
  if (contact_view && file.proto_.has_model())
    ReduceToContactView(file.proto_.mutable_model());  // an element set whole
  file.overrides_ = overrides;
  file.CheckFinite(file.proto_, "");
  // Tables from their CSV files (after the overrides: one may name another file).
  LoadCsvTables(
      &file.proto_, [&file](const std::string& given) { return file.PathBeside(given); },
      [&file](const std::string& path, const std::string& message) { file.Fail(path, message); });
  // Frames last, so that every override of a frame or of an element written in one counts.
  std::vector<std::pair<std::string, CopyTurn>> deferred;
  for (const PatternOrigin& o : file.pattern_origins_) {
    if (!o.turn.frame.empty()) deferred.emplace_back(o.expanded, o.turn);
  }
  ResolveReferences(
      &file.proto_,
      [&file](const std::string& path) -> std::optional<CopyTurn> {
        const PatternOrigin* o = file.CopyOf(path);
        return o != nullptr ? std::optional<CopyTurn>(o->turn) : std::nullopt;
      },
      deferred, [&file](const std::string& path, const std::string& message) { file.Fail(path, message); });
  // Bad definitions are refused even where no ${…} uses them; and every ${…} was replaced with
  // the values the parameters have here. A definition holding a ${…} itself (`value: ${b}`)
  // was read as 0 when the ${…} were replaced: it is refused, not used with two values.
  const ParameterValues values = file.EvaluateParameters();
  for (int i = 0; i < file.proto_.parameters_size() && !substituted.names.empty(); ++i) {
    const std::string& name = file.proto_.parameters(i).name();
    if (substituted.Find(name) != values.Find(name)) {
      file.Fail("parameters[" + std::to_string(i) + "]",
                "'" + name +
                    "' is written with ${…}, which the parameters cannot use; define it from others "
                    "with expression: \"…\"");
    }
  }
  // The name becomes the default output folder runs/<name>.
  if (file.proto_.has_name()) Checks(file).Name("name", true, file.proto_.name());
  return file;
}

void ScenarioFile::CheckFinite(const pb::Message& message, const std::string& prefix) const {
  // Every number of the schema is a finite one (no field gives inf or NaN a meaning): refused
  // here once, for every reader, with its place.
  const pb::Descriptor* descriptor = message.GetDescriptor();
  const pb::Reflection* reflection = message.GetReflection();
  for (int i = 0; i < descriptor->field_count(); ++i) {
    const pb::FieldDescriptor* field = descriptor->field(i);
    const std::string path = prefix.empty() ? field->name() : prefix + "." + field->name();
    const bool is_double = field->cpp_type() == pb::FieldDescriptor::CPPTYPE_DOUBLE;
    const bool is_message = field->cpp_type() == pb::FieldDescriptor::CPPTYPE_MESSAGE;
    if (!is_double && !is_message) continue;  // (the schema has no float fields)
    auto check = [&](double value, const std::string& where) {
      if (std::isfinite(value)) return;
      Fail(where, "must be a finite number, got " + std::string(std::isnan(value) ? "nan"
                                                                : value > 0       ? "inf"
                                                                                  : "-inf"));
    };
    if (field->is_repeated()) {
      const int size = reflection->FieldSize(message, field);
      for (int k = 0; k < size; ++k) {
        const std::string where = path + "[" + std::to_string(k) + "]";
        if (is_message) {
          CheckFinite(reflection->GetRepeatedMessage(message, field, k), where);
        } else {
          check(reflection->GetRepeatedDouble(message, field, k), where);
        }
      }
    } else if (reflection->HasField(message, field)) {
      if (is_message) {
        CheckFinite(reflection->GetMessage(message, field), path);
      } else {
        check(reflection->GetDouble(message, field), path);
      }
    }
  }
}

namespace {

// The last segment of an override: `value` into `field` of `message` (element `index` of a
// repeated field, or the whole field for -1); `given` is the value as the user wrote it.
void SetOverriddenField(const std::string& context, const std::string& given, pb::Message* message,
                        const pb::FieldDescriptor* field, int index, std::string value) {
  const pb::Reflection* reflection = message->GetReflection();
  // The last segment: parse "name: VALUE" as text format into a scratch copy of the parent
  // with the field cleared, then move the value over. This gives --set exactly the syntax
  // of the scenario file (enums by name, lists as [a, b, c], messages as { ... }).
  // A bare word is a string; a whole repeated field of strings is a list ["a", "b"].
  const bool string_list = field->is_repeated() && index < 0 && !value.empty() && value[0] == '[';
  if (field->type() == pb::FieldDescriptor::TYPE_STRING && !string_list && (value.empty() || value[0] != '"')) {
    value = "\"" + value + "\"";
  }
  std::unique_ptr<pb::Message> scratch(message->New());
  FirstErrorCollector errors;
  pb::TextFormat::Parser parser;
  parser.RecordErrorsTo(&errors);
  const std::string snippet = field->name() + ": " + value;
  if (!parser.ParseFromString(snippet, scratch.get()) || errors.has_error()) {
    throw InputError(context + ": value '" + given + "' does not fit field '" + field->name() + "' (" +
                     std::string(field->type_name()) + "): " + errors.Format("value"));
  }
  const pb::Reflection* scratch_reflection = scratch->GetReflection();
  if (index >= 0) {
    if (scratch_reflection->FieldSize(*scratch, field) != 1) {
      throw InputError(context + ": an element of '" + field->name() + "' takes one value");
    }
    // Copy the single parsed element into place.
    switch (field->cpp_type()) {
      case pb::FieldDescriptor::CPPTYPE_MESSAGE:
        reflection->MutableRepeatedMessage(message, field, index)
            ->CopyFrom(scratch_reflection->GetRepeatedMessage(*scratch, field, 0));
        break;
      case pb::FieldDescriptor::CPPTYPE_DOUBLE:
        reflection->SetRepeatedDouble(message, field, index, scratch_reflection->GetRepeatedDouble(*scratch, field, 0));
        break;
      case pb::FieldDescriptor::CPPTYPE_INT32:
        reflection->SetRepeatedInt32(message, field, index, scratch_reflection->GetRepeatedInt32(*scratch, field, 0));
        break;
      case pb::FieldDescriptor::CPPTYPE_STRING:
        reflection->SetRepeatedString(message, field, index, scratch_reflection->GetRepeatedString(*scratch, field, 0));
        break;
      default:
        throw InputError(context + ": setting one element of '" + field->name() +
                         "' is not supported; set the whole list");
    }
  } else {
    reflection->ClearField(message, field);
    // Swap the freshly parsed field in (MergeFrom of the scratch adds only what it holds).
    message->MergeFrom(*scratch);
  }
}

}  // namespace

void ScenarioFile::ApplyOverride(const std::string& argument) {
  const std::string context = "--set " + argument;
  const size_t eq = argument.find('=');
  if (eq == std::string::npos || eq == 0) {
    throw InputError(context + ": expected FIELD.PATH=VALUE, e.g. --set numerics.step=0.001");
  }
  const std::string path = argument.substr(0, eq);
  std::string value = argument.substr(eq + 1);
  const std::vector<PathSegment> segments = ParseFieldPath(path, context);

  pb::Message* message = &proto_;
  std::string normalised;
  for (size_t s = 0; s < segments.size(); ++s) {
    const PathSegment& segment = segments[s];
    const pb::Descriptor* descriptor = message->GetDescriptor();
    const pb::FieldDescriptor* field = descriptor->FindFieldByName(segment.field);
    if (field == nullptr) {
      throw InputError(context + ": " + descriptor->name() + " has no field '" + segment.field +
                       "'; its fields are: " + KnownFields(descriptor));
    }
    const pb::Reflection* reflection = message->GetReflection();
    if (!normalised.empty()) normalised += ".";
    normalised += segment.field;
    const bool last = s + 1 == segments.size();
    int index = -1;
    if (segment.has_key) {
      if (!field->is_repeated()) {
        throw InputError(context + ": '" + segment.field + "' is not a repeated field; drop the [" + segment.key + "]");
      }
      index = ResolveIndex(*message, field, segment.key);
      if (index < 0) {
        throw InputError(context + ": '" + segment.field + "' has " +
                         std::to_string(reflection->FieldSize(*message, field)) + " elements and none matches [" +
                         segment.key + "] (give a 0-based index or the element's name)");
      }
      normalised.append("[")
          .append(std::to_string(index))
          .append("]");  // (not a + chain: GCC 12 -Wrestrict false positive)
    } else if (field->is_repeated() && !last) {
      throw InputError(context + ": '" + segment.field + "' is repeated; say which element, e.g. " + segment.field +
                       "[0]");
    }

    if (!last) {
      if (field->cpp_type() != pb::FieldDescriptor::CPPTYPE_MESSAGE) {
        throw InputError(context + ": '" + segment.field + "' is a value, it has no sub-fields");
      }
      message = index >= 0 ? reflection->MutableRepeatedMessage(message, field, index)
                           : reflection->MutableMessage(message, field);
      continue;
    }

    SetOverriddenField(context, argument.substr(eq + 1), message, field, index, value);
  }
  overridden_.emplace_back(normalised, argument);
}

void ScenarioFile::NoteCopyOverride(const std::string& argument) {
  const std::string& path = overridden_.back().first;  // normalised by ApplyOverride
  // A contact process's endpoint is per copy by nature (the launcher sets each one's).
  const std::string endpoint = ".endpoint";
  if (path.size() >= endpoint.size() && path.compare(path.size() - endpoint.size(), endpoint.size(), endpoint) == 0) {
    return;
  }
  if (const PatternOrigin* o = CopyOf(path)) {
    warnings_.push_back("--set " + argument + " changes copy " + std::to_string(o->copy) + " of pattern '" +
                        o->pattern + "' only (" + o->expanded + " is that copy of " + o->source +
                        "); to change every copy, set " + o->source + path.substr(o->expanded.size()));
  }
}

const PatternOrigin* ScenarioFile::CopyOf(const std::string& field_path) const {
  for (const PatternOrigin& o : pattern_origins_) {
    if (Within(field_path, o.expanded)) return &o;
  }
  return nullptr;
}

std::filesystem::path ScenarioFile::PathBeside(const std::string& given) const {
  std::filesystem::path path(given);
  if (path.is_relative()) path = std::filesystem::path(path_).parent_path() / path;
  return path;
}

std::string ScenarioFile::Where(const std::string& field_path) const {
  if (const std::string set = OverrideOf(field_path); !set.empty()) return set;  // a copy's own override
  if (const PatternOrigin* o = CopyOf(field_path)) {
    return WhereInFile(o->source + field_path.substr(o->expanded.size())) + " (copy " + std::to_string(o->copy) +
           " of pattern '" + o->pattern + "')";
  }
  return WhereInFile(field_path);
}

std::string ScenarioFile::OverrideOf(const std::string& field_path) const {
  for (auto it = overridden_.rbegin(); it != overridden_.rend(); ++it) {
    if (Within(field_path, it->first)) return "--set " + it->second;
  }
  return "";
}

std::string ScenarioFile::WhereInFile(const std::string& field_path) const {
  if (const std::string set = OverrideOf(field_path); !set.empty()) return set;
  std::vector<PathSegment> segments;
  try {
    segments = ParseFieldPath(field_path, path_);
  } catch (const InputError&) {
    return path_;
  }
  std::string best = path_;
  auto format = [this](const pb::TextFormat::ParseLocation& location) {
    return Place(location.line + 1, location.column + 1);
  };
  const pb::Descriptor* descriptor = proto_.GetDescriptor();
  const pb::TextFormat::ParseInfoTree* tree = tree_.get();
  for (size_t s = 0; s < segments.size() && tree != nullptr && descriptor != nullptr; ++s) {
    const pb::FieldDescriptor* field = descriptor->FindFieldByName(segments[s].field);
    if (field == nullptr) break;
    int index = -1;
    if (field->is_repeated()) {
      index = segments[s].has_key && IsDecimal(segments[s].key) ? ParseIndex(segments[s].key) : 0;
      if (index < 0) break;
    }
    const pb::TextFormat::ParseLocation location = tree->GetLocation(field, index);
    if (location.line < 0) {
      // A missing element of a repeated scalar list: point at the list's first value.
      if (index > 0) {
        const pb::TextFormat::ParseLocation first = tree->GetLocation(field, 0);
        if (first.line >= 0) best = format(first);
      }
      break;
    }
    best = format(location);
    if (field->cpp_type() != pb::FieldDescriptor::CPPTYPE_MESSAGE) break;
    tree = tree->GetTreeForNested(field, index);
    descriptor = field->message_type();
  }
  return best;
}

void ScenarioFile::Fail(const std::string& field_path, const std::string& message) const {
  throw InputError(Where(field_path) + ": " + field_path + ": " + message);
}

namespace {

// `open`: the message types being materialised on the way down. A type that contains itself
// (Study.Run.reference) is materialised where it is set only: created wherever it is unset, it
// would recurse for ever (found by `--print-scenario` on the Puma engagement: a stack overflow).
void MaterializeDefaults(pb::Message* message, std::vector<const pb::Descriptor*>* open) {
  const pb::Descriptor* descriptor = message->GetDescriptor();
  const pb::Reflection* reflection = message->GetReflection();
  open->push_back(descriptor);
  for (int i = 0; i < descriptor->field_count(); ++i) {
    const pb::FieldDescriptor* field = descriptor->field(i);
    if (field->is_repeated() || field->containing_oneof() != nullptr) continue;
    if (field->cpp_type() == pb::FieldDescriptor::CPPTYPE_MESSAGE) {
      const bool recursive = std::find(open->begin(), open->end(), field->message_type()) != open->end();
      if (!recursive || reflection->HasField(*message, field)) {
        MaterializeDefaults(reflection->MutableMessage(message, field), open);
      }
      continue;
    }
    if (reflection->HasField(*message, field) || !field->has_default_value()) continue;
    switch (field->cpp_type()) {
      case pb::FieldDescriptor::CPPTYPE_DOUBLE:
        reflection->SetDouble(message, field, field->default_value_double());
        break;
      case pb::FieldDescriptor::CPPTYPE_INT32:
        reflection->SetInt32(message, field, field->default_value_int32());
        break;
      case pb::FieldDescriptor::CPPTYPE_BOOL:
        reflection->SetBool(message, field, field->default_value_bool());
        break;
      case pb::FieldDescriptor::CPPTYPE_ENUM:
        reflection->SetEnum(message, field, field->default_value_enum());
        break;
      case pb::FieldDescriptor::CPPTYPE_STRING:
        reflection->SetString(message, field, field->default_value_string());
        break;
      default:
        break;
    }
  }
  open->pop_back();
}

}  // namespace

void MaterializeDefaults(pb::Message* message) {
  std::vector<const pb::Descriptor*> open;
  MaterializeDefaults(message, &open);
}

}  // namespace cosim::interface
