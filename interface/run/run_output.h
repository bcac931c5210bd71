#pragma once
// The run contract's files in one output folder:
//   history.csv   `time` then one column per probe, one row per output step, 17 digits;
//   summary.json  the RunSummary message (proto/run_summary.proto) as JSON;
//   log.txt       what the run said, also echoed to stderr.
// Rows are buffered and flushed at the end and whenever the log is written, so a failed
// run still holds every row up to its last accepted step.
#include <cstdio>
#include <string>
#include <vector>

#include "interface/run/errors.h"
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

class RunOutput {
 public:
  // Creates `folder` (and parents) and opens its files. Throws InputError naming the
  // folder if it cannot be created or written.
  RunOutput(const std::string& folder, const std::vector<std::string>& probe_names);
  ~RunOutput();
  RunOutput(const RunOutput&) = delete;
  RunOutput& operator=(const RunOutput&) = delete;

  const std::string& folder() const { return folder_; }
  int probe_count() const { return probe_count_; }
  void WriteRow(double time, const std::vector<double>& values);
  void Log(const std::string& line);
  void Flush();

  run::RunSummary& summary() { return summary_; }
  // Sets status, exit code and reason, flushes history.csv and writes summary.json.
  void Finish(ExitCode code, const std::string& reason);

 private:
  std::string folder_;
  int probe_count_ = 0;
  std::FILE* history_ = nullptr;
  std::FILE* log_ = nullptr;
  run::RunSummary summary_;
  std::vector<char> history_buffer_;
};

// Writes a RunSummary as JSON to `path` (used by RunOutput and by the launcher).
void WriteSummaryJson(const run::RunSummary& summary, const std::string& path);

}  // namespace cosim::interface
