#pragma once
// The run contract's files in one output folder:
//   history.csv   `time` then one column per probe, one row per output step, 17 digits;
//   summary.json  the RunSummary message (proto/run_summary.proto) as JSON;
//   log.txt       what the run said, also echoed to stderr.
// The folder is locked (flock) for the run: a second run given the same folder is refused.
// Rows reach the disk at least every second (and whenever the log is written), so a run that
// fails or is killed still holds its rows up to about its last second. A write that fails (a
// full disk) is not ignored: the run ends with exit 2 naming the file and the system's reason.
#include <chrono>
#include <cstdio>
#include <functional>
#include <memory>
#include <ostream>
#include <string>
#include <vector>

#include "interface/base/errors.h"
#include "interface/base/folder_lock.h"
#include "interface/base/whole_file.h"
#include "run_summary.pb.h"

namespace cosim::interface {

// Per-step iteration counts (Newton, coupling, LCP) summarised as total, mean and max.
class IterationCounter {
 public:
  void Add(long long iterations) {
    total_ += iterations;
    ++steps_;
    if (iterations > max_) max_ = iterations;
  }
  void Fill(run::IterationStats* stats) const;
  long long total() const { return total_; }

 private:
  long long total_ = 0;
  long long steps_ = 0;
  long long max_ = 0;
};

// `message` in binary protobuf as `folder`/final_state.pb, a run's saved state
// (proto/state.proto), whole or not at all (WriteWholeFile); InputError naming the file if it
// cannot be written.
void WriteFinalState(const std::string& folder, const google::protobuf::Message& message);

// A text file of an output folder written row by row: buffered, flushed at least every
// second, every write checked. Rows are written with Print (printf format) and ended with
// EndRow, which throws InputError naming the file at the first failed write.
class OutputFile {
 public:
  // Opens (truncates) `path`; InputError naming it if it cannot.
  explicit OutputFile(const std::string& path);
  ~OutputFile();
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  std::FILE* get() { return file_; }
  // The row is complete: flushes if a second has passed; throws at a failed write.
  void EndRow();
  // Flushes; false (and error() says why) if any write so far failed. Never throws.
  bool Flush();
  const std::string& error() const { return error_; }
  const std::string& path() const { return path_; }

 private:
  void Check();  // records the first failure
  std::string path_;
  std::FILE* file_ = nullptr;
  std::vector<char> buffer_;
  std::chrono::steady_clock::time_point last_flush_;
  std::string error_;
};

class RunOutput {
 public:
  // Creates `folder` (and parents), locks it and opens its files. Throws InputError naming
  // the folder if it cannot be created or written, or another run holds it.
  RunOutput(const std::string& folder, const std::vector<std::string>& probe_names);
  ~RunOutput();
  RunOutput(const RunOutput&) = delete;
  RunOutput& operator=(const RunOutput&) = delete;

  const std::string& folder() const { return folder_; }
  int probe_count() const { return probe_count_; }
  // Throws InputError when history.csv cannot be written.
  void WriteRow(double time, const std::vector<double>& values);
  void Log(const std::string& line);  // never throws

  run::RunSummary& summary() { return summary_; }
  // Flushes history.csv, sets status, exit code and reason (a failed history write turns an
  // ok run into exit 2 with its reason) and writes summary.json. Returns the exit code the
  // run ends with: `code`, or 2 if the outputs could not be written.
  ExitCode Finish(ExitCode code, const std::string& reason);

 private:
  std::string folder_;
  int probe_count_ = 0;
  std::unique_ptr<FolderLock> lock_;
  std::unique_ptr<OutputFile> history_;
  std::FILE* log_ = nullptr;
  run::RunSummary summary_;
};

// Writes a RunSummary as JSON to `path` (used by RunOutput and by the launcher), making its
// folder if it is not there, whole or not at all. Returns false (and says why on stderr) if the
// file cannot be written.
bool WriteSummaryJson(const run::RunSummary& summary, const std::string& path);
// Reads one back; false if there is none or it does not parse.
[[nodiscard]] bool ReadSummaryJson(const std::string& path, run::RunSummary* summary);

// Removes what an earlier run of `folder` wrote as visual output (visual.pvd, scene.pvd, the
// frames and legend in visual/), and nothing else: never a folder that is another run's.
void RemoveEarlierVisualOutput(const std::string& folder);

}  // namespace cosim::interface
