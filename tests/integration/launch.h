#pragma once
// Helpers of the end-to-end tests: run `cosim_launch` (what `scripts/cosim run` calls) into a
// scratch folder of this test process and read back what the run wrote.
#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "run_summary.pb.h"

namespace cosim::test {

namespace fs = std::filesystem;

struct Result {
  int code = -1;
  std::string output;
};

inline std::string Slurp(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

inline fs::path TestRoot() { return fs::temp_directory_path() / ("cosim_test_" + std::to_string(getpid())); }

// Removes this process's scratch folders when the tests end.
class ScratchCleanup : public ::testing::Environment {
 public:
  void TearDown() override { fs::remove_all(TestRoot()); }
};
inline const auto* const kCleanup = ::testing::AddGlobalTestEnvironment(new ScratchCleanup);

inline fs::path TempDir(const std::string& name) {
  const fs::path dir = TestRoot() / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

inline Result Launch(const std::string& arguments) {
  const fs::path log = TempDir("log_" + std::to_string(std::hash<std::string>{}(arguments))) / "out.txt";
  const std::string command =
      std::string(COSIM_BIN_DIR) + "/cosim_launch " + arguments + " > " + log.string() + " 2>&1";
  const int status = std::system(command.c_str());
  return Result{WIFEXITED(status) ? WEXITSTATUS(status) : -1, Slurp(log)};
}

inline cosim::run::RunSummary ReadSummary(const fs::path& folder) {
  cosim::run::RunSummary summary;
  const auto status = google::protobuf::util::JsonStringToMessage(Slurp(folder / "summary.json"), &summary);
  EXPECT_TRUE(status.ok()) << status.ToString();
  return summary;
}

// A CSV file of numbers with a header row.
struct Table {
  std::vector<std::string> header;
  std::vector<std::vector<double>> rows;
  size_t size() const { return rows.size(); }
  const std::vector<double>& operator[](size_t k) const { return rows[k]; }
  // The column named `name` (fails the test if there is none).
  std::vector<double> Column(const std::string& name) const {
    for (size_t c = 0; c < header.size(); ++c) {
      if (header[c] != name) continue;
      std::vector<double> out;
      for (const auto& r : rows) out.push_back(r[c]);
      return out;
    }
    ADD_FAILURE() << "no column '" << name << "'";
    return {};
  }
};

inline Table ReadTable(const fs::path& file) {
  std::ifstream in(file);
  Table t;
  std::string line, cell;
  std::getline(in, line);
  std::stringstream h(line);
  while (std::getline(h, cell, ',')) t.header.push_back(cell);
  while (std::getline(in, line)) {
    std::vector<double> row;
    std::stringstream s(line);
    while (std::getline(s, cell, ',')) {
      char* end = nullptr;
      const double v = std::strtod(cell.c_str(), &end);
      row.push_back(end != cell.c_str() && *end == '\0' ? v : std::nan(""));  // text cells: NaN
    }
    t.rows.push_back(row);
  }
  return t;
}

inline std::vector<std::vector<double>> ReadHistory(const fs::path& file) { return ReadTable(file).rows; }

}  // namespace cosim::test
