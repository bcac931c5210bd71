#include "interface/run/run_output.h"

#include <google/protobuf/util/json_util.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <memory>
#include <sstream>

#include "interface/base/input_file.h"

namespace cosim::interface {

void IterationCounter::Fill(run::IterationStats* stats) const {
  stats->set_total(static_cast<double>(total_));
  stats->set_mean_per_step(steps_ > 0 ? static_cast<double>(total_) / static_cast<double>(steps_) : 0.0);
  stats->set_max_per_step(static_cast<int>(std::min<long long>(max_, std::numeric_limits<int>::max())));
}

OutputFile::OutputFile(const std::string& path) : path_(path), last_flush_(std::chrono::steady_clock::now()) {
  file_ = std::fopen(path.c_str(), "w");
  if (file_ == nullptr) {
    throw InputError("cannot write " + path + ": " + std::strerror(errno) + " (choose a writable output folder)");
  }
  buffer_.resize(1 << 16);
  std::setvbuf(file_, buffer_.data(), _IOFBF, buffer_.size());
}

OutputFile::~OutputFile() {
  if (file_ != nullptr) std::fclose(file_);
}

void OutputFile::Check() {
  if (error_.empty() && std::ferror(file_) != 0) {
    error_ = "writing " + path_ + " failed: " + std::strerror(errno != 0 ? errno : EIO);
  }
}

void OutputFile::EndRow() {
  const auto now = std::chrono::steady_clock::now();
  if (now - last_flush_ >= std::chrono::seconds(1)) {
    Flush();
    last_flush_ = now;
  }
  Check();
  if (!error_.empty()) throw InputError(error_ + " (is the disk full?)");
}

bool OutputFile::Flush() {
  errno = 0;
  if (std::fflush(file_) != 0 && error_.empty()) error_ = "writing " + path_ + " failed: " + std::strerror(errno);
  Check();
  return error_.empty();
}

void RemoveEarlierVisualOutput(const std::string& folder) {
  // Only what a run of this folder writes: the two indexes as files, and in visual/ the frames
  // (NNNNNN.vtu) and legend.csv. A folder where an index would go, or visual/ as another run's
  // output folder (a running run's --out P/visual), is not this folder's output: it was removed
  // whole, and the running run lost its history.
  namespace fs = std::filesystem;
  std::error_code ec;
  for (const char* index : {"/visual.pvd", "/scene.pvd"}) {
    const fs::file_status st = fs::symlink_status(folder + index, ec);
    if (fs::is_regular_file(st) || fs::is_symlink(st)) fs::remove(folder + index, ec);
  }
  const std::string visual = folder + "/visual";
  const fs::file_status st = fs::symlink_status(visual, ec);
  if (fs::is_symlink(st)) fs::remove(visual, ec);  // (the link, not what it points to)
  if (!fs::is_directory(st) || HeldByAnotherRun(visual)) return;
  for (const fs::directory_entry& e : fs::directory_iterator(visual, ec)) {
    const std::string name = e.path().filename().string();
    // (NNNNNN.vtu: six digits or more, as VisualSeries names them)
    const size_t digits = name.size() >= 4 ? name.size() - 4 : 0;
    const bool frame = digits >= 6 && name.compare(digits, 4, ".vtu") == 0 &&
                       std::all_of(name.begin(), name.begin() + static_cast<std::ptrdiff_t>(digits),
                                   [](char c) { return c >= '0' && c <= '9'; });
    if ((frame || name == "legend.csv") && e.is_regular_file(ec)) fs::remove(e.path(), ec);
  }
  fs::remove(visual, ec);  // (only if nothing else is left in it)
}

RunOutput::RunOutput(const std::string& folder, const std::vector<std::string>& probe_names)
    : folder_(folder), probe_count_(static_cast<int>(probe_names.size())) {
  if (folder.empty()) throw InputError("--out: the output folder is an empty string; give a folder");
  std::error_code error;
  std::filesystem::create_directories(folder, error);
  if (error) {
    throw InputError("--out " + folder + ": cannot create the output folder: " + error.message() +
                     " (choose a writable folder)");
  }
  // One run per folder (FolderLock).
  lock_ = std::make_unique<FolderLock>(folder);
  switch (lock_->outcome()) {
    case FolderLock::Outcome::kTaken:
      break;
    case FolderLock::Outcome::kCannotOpen:
      throw InputError("--out " + folder + ": cannot open the output folder: " + lock_->why());
    case FolderLock::Outcome::kHeldByAnotherRun:
    case FolderLock::Outcome::kCannotLock:
      throw InputError("--out " + folder + ": the output folder is in use by another run" +
                       (lock_->why().empty() ? std::string() : " (" + lock_->why() + ")") +
                       "; give each run its own folder");
  }
  // An earlier run's summary would describe this run if it were killed before its own; its
  // visual output would mix with this run's frames (or stand for them if this run writes none).
  ::unlink((folder + "/summary.json").c_str());
  RemoveEarlierVisualOutput(folder);
  history_ = std::make_unique<OutputFile>(folder + "/history.csv");
  const std::string log_path = folder + "/log.txt";
  log_ = std::fopen(log_path.c_str(), "w");
  if (log_ == nullptr) {
    throw InputError("--out " + folder + ": cannot write " + log_path + ": " + std::strerror(errno));
  }
  std::FILE* h = history_->get();
  std::fputs("time", h);
  for (const std::string& name : probe_names) {
    std::fputc(',', h);
    std::fputs(name.c_str(), h);
  }
  std::fputc('\n', h);
}

RunOutput::~RunOutput() {
  history_.reset();
  if (log_ != nullptr) std::fclose(log_);
}

void RunOutput::WriteRow(double time, const std::vector<double>& values) {
  COSIM_ASSERT(static_cast<int>(values.size()) == probe_count_, "probe row size");
  std::FILE* h = history_->get();
  std::fprintf(h, "%.17g", time);
  for (double v : values) std::fprintf(h, ",%.17g", v);
  std::fputc('\n', h);
  history_->EndRow();
}

void RunOutput::Log(const std::string& line) {
  std::fprintf(stderr, "%s\n", line.c_str());
  std::fprintf(log_, "%s\n", line.c_str());
  std::fflush(log_);
  history_->Flush();
}

ExitCode RunOutput::Finish(ExitCode code, const std::string& reason) {
  std::string why = reason;
  if (!history_->Flush() && code == ExitCode::kOk) {
    code = ExitCode::kBadInput;
    why = "--out " + folder_ + ": " + history_->error() + " (is the disk full?)";
    Log("error: " + why);
  }
  summary_.set_status(code == ExitCode::kOk ? "ok" : "failed");
  summary_.set_exit_code(static_cast<int>(code));
  summary_.set_reason(why);
  if (std::fflush(log_) != 0 || std::ferror(log_) != 0) {
    std::cerr << "error: writing " << folder_ << "/log.txt failed\n";
  }
  if (!WriteSummaryJson(summary_, folder_ + "/summary.json")) return ExitCode::kBadInput;
  return code;
}

bool WriteSummaryJson(const run::RunSummary& summary, const std::string& path) {
  std::string json;
  google::protobuf::util::JsonPrintOptions options;
  options.add_whitespace = true;
  options.preserve_proto_field_names = true;
  options.always_print_primitive_fields = true;
  const auto status = google::protobuf::util::MessageToJsonString(summary, &json, options);
  COSIM_ASSERT(status.ok(), "RunSummary to JSON: " + status.ToString());
  // Into a folder made if it is not there (the launcher's summary of a process killed before it
  // made its own), written whole or not at all (a temporary file renamed over
  // it): a process killed while it writes leaves no half summary taken for its outcome.
  std::error_code absent;
  std::filesystem::create_directories(std::filesystem::path(path).parent_path(), absent);
  const WrittenFile written = WriteWholeFile(path, [&json](std::ostream& out) { out << json; });
  if (!written.ok()) {
    std::cerr << "error: " << written.why << " (the run's outcome is lost)\n";
    return false;
  }
  return true;
}

bool ReadSummaryJson(const std::string& path, run::RunSummary* summary) {
  const InputFile text = ReadInputFile(path, kMaxOutputBytes);  // (a regular file, bounded)
  return text.ok() && google::protobuf::util::JsonStringToMessage(text.text, summary).ok();
}

void WriteFinalState(const std::string& folder, const google::protobuf::Message& message) {
  const std::string path = folder + "/final_state.pb";
  const WrittenFile written = WriteWholeFile(path, [&message](std::ostream& out) {
    if (!message.SerializeToOstream(&out)) out.setstate(std::ios::failbit);
  });
  if (!written.ok()) throw InputError(written.why + " (choose a writable output folder; is the disk full?)");
}

}  // namespace cosim::interface
