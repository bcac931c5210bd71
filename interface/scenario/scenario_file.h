#pragma once
// A scenario file as loaded for a run: the parsed message, where each field came from
// (file:line:col, or the `--set` argument that overrode it), and the error helpers that
// name that place.
#include <google/protobuf/text_format.h>

#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "interface/scenario/contact_view.h"
#include "interface/scenario/pattern.h"
#include "scenario.pb.h"

namespace cosim::interface {

class ScenarioFile {
 public:
  // Reads `path` (protobuf text format, schema proto/scenario.proto), then applies each
  // override "FIELD.PATH=VALUE" in order. Throws InputError naming file:line:col for syntax
  // errors and unknown fields, and the override for a bad `--set`.
  // Only a regular file of at most kMaxScenarioBytes is read. Every number must be finite.
  // `view` kContactProcess: the part a coupled run's contact process reads (contact_view.h).
  static ScenarioFile Load(const std::string& path, const std::vector<std::string>& overrides,
                           ScenarioView view = ScenarioView::kWhole);
  static constexpr long long kMaxScenarioBytes = 64LL << 20;
  // The same from text in memory (tests); `display_name` stands in for the file name.
  static ScenarioFile Parse(const std::string& text, const std::string& display_name,
                            const std::vector<std::string>& overrides, ScenarioView view = ScenarioView::kWhole);

  ScenarioFile(ScenarioFile&&) noexcept;
  ScenarioFile& operator=(ScenarioFile&&) noexcept;
  ~ScenarioFile();

  const scenario::Scenario& proto() const { return proto_; }
  const std::string& path() const { return path_; }
  // A path the scenario gives (initial_state, c81_file): relative to the scenario file's folder,
  // absolute as it is.
  std::filesystem::path PathBeside(const std::string& given) const;
  const std::vector<std::string>& overrides() const { return overrides_; }
  // What the input does that it may not mean, one sentence each: an override that reaches one
  // copy of a pattern (the template's own path is given). The launcher prints them; every
  // run's summary.json lists them.
  const std::vector<std::string>& warnings() const { return warnings_; }

  // Where the field at `field_path` was given: "--set ARG" if an override set it or an
  // enclosing field, else "file:line:col" of the field, or of its nearest enclosing field
  // that is present in the file, or the file name alone. A field of a pattern's copy is
  // placed at the pattern's template, with "(copy k of pattern 'NAME')".
  std::string Where(const std::string& field_path) const;

  // Throws InputError "<where>: <field_path>: <message>".
  [[noreturn]] void Fail(const std::string& field_path, const std::string& message) const;

 private:
  ScenarioFile();
  // Parses protobuf text into proto_ (locations into tree_); InputError naming file:line:col.
  void ParseText(const std::string& text);
  // "file:line:col" of a place (1-based) in the expanded text: the included file's own line.
  std::string Place(int line, int column) const;
  // The parameters' values (Scenario.parameters), each checked in order: InputError naming the
  // parameter's place for a bad name, a repeated one, no definition or a bad expression.
  struct ParameterValues {
    std::map<std::string, double> values;
    std::string names;  // in definition order, "R, c, droop"
    std::optional<double> Find(const std::string& name) const;
  };
  ParameterValues EvaluateParameters() const;
  // The joined text with every ${…} replaced by its value (Scenario.parameters read from the
  // text with each ${…} blanked to the same width, and their `--set` overrides applied);
  // `parameters` gets those values (empty if there is no ${…}).
  static std::string ExpandParameters(const std::string& joined,
                                      const std::vector<std::pair<std::string, int>>& origins,
                                      const std::string& display_name, const std::vector<std::string>& overrides,
                                      ParameterValues* parameters);
  void ApplyOverride(const std::string& argument);
  // After ApplyOverride of `argument`: a warning if it set a field of a pattern's copy.
  void NoteCopyOverride(const std::string& argument);
  // InputError at the first non-finite number under `message` (at field path `prefix`).
  void CheckFinite(const google::protobuf::Message& message, const std::string& prefix) const;

  scenario::Scenario proto_;
  std::string path_;
  std::vector<std::string> overrides_;
  std::vector<std::string> warnings_;
  // For each line of the text as parsed (includes expanded): the file and line it came from.
  std::vector<std::pair<std::string, int>> line_origins_;
  std::unique_ptr<google::protobuf::TextFormat::ParseInfoTree> tree_;
  // Normalised paths (indices, not names) set by overrides, with their argument.
  std::vector<std::pair<std::string, std::string>> overridden_;
  // Where the patterns' copies came from (ExpandPatterns).
  std::vector<PatternOrigin> pattern_origins_;
  std::string WhereInFile(const std::string& field_path) const;
  // The pattern copy that `field_path` lies in (it or a field under it), or nullptr.
  const PatternOrigin* CopyOf(const std::string& field_path) const;
  // "--set ARG" if an override set the field or an enclosing one, else empty.
  std::string OverrideOf(const std::string& field_path) const;
};

// One step of a field path: a field name and, on repeated fields, an index or element name.
struct PathSegment {
  std::string field;
  std::string key;  // empty, a decimal index, or the `name` of a repeated element
  bool has_key = false;
};

// Splits "a.b[2].c[name]" into segments; throws InputError naming `context` if malformed.
std::vector<PathSegment> ParseFieldPath(const std::string& path, const std::string& context);

// Sets every unset optional scalar that has a declared default to that default, creating
// the sub-messages of `message` that hold defaults, so that a summary shows every setting
// actually used. Oneof members are left alone.
void MaterializeDefaults(google::protobuf::Message* message);

}  // namespace cosim::interface
