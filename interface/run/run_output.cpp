#include "interface/run/run_output.h"

#include <google/protobuf/util/json_util.h>

#include <algorithm>
#include <cerrno>
#include <limits>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>

namespace cosim::interface {

void IterationCounter::Fill(run::IterationStats* stats) const {
  stats->set_total(static_cast<double>(total_));
  stats->set_mean_per_step(steps_ > 0 ? static_cast<double>(total_) / static_cast<double>(steps_) : 0.0);
  stats->set_max_per_step(static_cast<int>(std::min<long long>(max_, std::numeric_limits<int>::max())));
}

RunOutput::RunOutput(const std::string& folder, const std::vector<std::string>& probe_names)
    : folder_(folder), probe_count_(static_cast<int>(probe_names.size())) {
  std::error_code error;
  std::filesystem::create_directories(folder, error);
  if (error) {
    throw InputError("--out " + folder + ": cannot create the output folder: " + error.message() +
                     " (choose a writable folder)");
  }
  const std::string history_path = folder + "/history.csv";
  history_ = std::fopen(history_path.c_str(), "w");
  if (history_ == nullptr) {
    throw InputError("--out " + folder + ": cannot write " + history_path + ": " + std::strerror(errno) +
                     " (choose a writable folder)");
  }
  history_buffer_.resize(1 << 16);
  std::setvbuf(history_, history_buffer_.data(), _IOFBF, history_buffer_.size());
  const std::string log_path = folder + "/log.txt";
  log_ = std::fopen(log_path.c_str(), "w");
  if (log_ == nullptr) {
    throw InputError("--out " + folder + ": cannot write " + log_path + ": " + std::strerror(errno));
  }
  std::fputs("time", history_);
  for (const std::string& name : probe_names) {
    std::fputc(',', history_);
    std::fputs(name.c_str(), history_);
  }
  std::fputc('\n', history_);
}

RunOutput::~RunOutput() {
  if (history_ != nullptr) std::fclose(history_);
  if (log_ != nullptr) std::fclose(log_);
}

void RunOutput::WriteRow(double time, const std::vector<double>& values) {
  COSIM_ASSERT(static_cast<int>(values.size()) == probe_count_, "probe row size");
  std::fprintf(history_, "%.17g", time);
  for (double v : values) std::fprintf(history_, ",%.17g", v);
  std::fputc('\n', history_);
}

void RunOutput::Log(const std::string& line) {
  std::fprintf(stderr, "%s\n", line.c_str());
  std::fprintf(log_, "%s\n", line.c_str());
  Flush();
}

void RunOutput::Flush() {
  std::fflush(history_);
  std::fflush(log_);
}

void RunOutput::Finish(ExitCode code, const std::string& reason) {
  summary_.set_status(code == ExitCode::kOk ? "ok" : "failed");
  summary_.set_exit_code(static_cast<int>(code));
  summary_.set_reason(reason);
  Flush();
  WriteSummaryJson(summary_, folder_ + "/summary.json");
}

void WriteSummaryJson(const run::RunSummary& summary, const std::string& path) {
  std::string json;
  google::protobuf::util::JsonPrintOptions options;
  options.add_whitespace = true;
  options.preserve_proto_field_names = true;
  options.always_print_primitive_fields = true;
  const auto status = google::protobuf::util::MessageToJsonString(summary, &json, options);
  COSIM_ASSERT(status.ok(), "RunSummary to JSON: " + status.ToString());
  std::ofstream out(path);
  out << json;
  if (!out) std::cerr << "error: cannot write " << path << "\n";
}

}  // namespace cosim::interface
