// Seeded mutations of the shipped scenarios through `cosim_launch`: whatever the
// mutation — a number replaced by 0, −1, ±1e308, NaN, inf, 2³¹ − 1, a line deleted or doubled,
// a name emptied or made "..", a file cut short — the run ends with exit 0, 2, 3 or 4 and a
// summary.json in its output folder: never a signal, a hang or a sanitizer report.
//
// The suite runs kBatches × kCasesPerBatch cases from a fixed seed (each batch a test, so that
// ctest spreads them over the cores). `scripts/cosim fuzz [CASES] [SEED]` runs more, with other
// seeds (COSIM_FUZZ_CASES, COSIM_FUZZ_SEED), and under the asan preset with the sanitizers.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "tests/integration/launch.h"

namespace {

using namespace cosim::test;

constexpr int kBatches = 6;
constexpr int kCasesPerBatch = 50;
constexpr double kWallLimit = 60.0;  // [s] per case: longer is a hang

long EnvOr(const char* name, long fallback) {
  const char* v = std::getenv(name);
  return v == nullptr ? fallback : std::strtol(v, nullptr, 10);
}

std::vector<fs::path> Corpus() {
  std::vector<fs::path> files;
  for (const char* folder : {"scenarios", "scenarios/hard", "tests/data"}) {
    for (const auto& e : fs::directory_iterator(fs::path(COSIM_SOURCE_DIR) / folder)) {
      if (e.path().extension() == ".pbtxt") files.push_back(e.path());
    }
  }
  std::sort(files.begin(), files.end());
  return files;
}

// Where a number starts: a digit, or '-' before one, after a blank, '[', ',' or ':'.
bool NumberStartsAt(const std::string& text, size_t i) {
  const auto digit = [&](size_t k) { return k < text.size() && std::isdigit(static_cast<unsigned char>(text[k])); };
  const bool starts = digit(i) || (text[i] == '-' && digit(i + 1));
  const bool after = i == 0 || std::isspace(static_cast<unsigned char>(text[i - 1])) || text[i - 1] == '[' ||
                     text[i - 1] == ',' || text[i - 1] == ':';
  return starts && after;
}

size_t NumberLength(const std::string& text, size_t i) {
  size_t end = i + 1;
  while (end < text.size() && (std::isdigit(static_cast<unsigned char>(text[end])) ||
                               std::string(".eE+-").find(text[end]) != std::string::npos)) {
    ++end;
  }
  return end - i;
}

// Keeps every run short: end_time at most 0.05 s (before the mutation, which may change it
// again). (No <regex>: GCC 12 warns inside it under the sanitizers' -O2.)
std::string Shorten(std::string text) {
  const std::string key = "end_time:";
  for (size_t at = text.find(key); at != std::string::npos; at = text.find(key, at + 1)) {
    size_t i = at + key.size();
    while (i < text.size() && text[i] == ' ') ++i;
    if (i < text.size() && NumberStartsAt(text, i)) text.replace(i, NumberLength(text, i), "0.05");
  }
  return text;
}

struct Mutation {
  std::string text;
  std::string what;
};

Mutation Mutate(const std::string& original, std::mt19937_64& rng) {
  static const std::vector<std::string> numbers = {"0",
                                                   "-1",
                                                   "1e308",
                                                   "-1e308",
                                                   "1e-308",
                                                   "nan",
                                                   "inf",
                                                   "-inf",
                                                   "2147483647",
                                                   "-2147483648",
                                                   "99999999999999999999",
                                                   "0.5",
                                                   "3",
                                                   "46341"};
  static const std::vector<std::string> strings = {
      "\"\"", "\"..\"", "\".\"", "\"a b\"", "\"../../escaped\"", "\"" + std::string(300, 'n') + "\"", "\"ground\""};
  auto pick = [&](size_t n) { return std::uniform_int_distribution<size_t>(0, n - 1)(rng); };
  std::string text = original;
  const int kind = static_cast<int>(pick(6));
  auto numbers_in = [&]() {
    std::vector<std::pair<size_t, size_t>> found;
    for (size_t i = 0; i < text.size(); ++i) {
      if (!NumberStartsAt(text, i)) continue;
      found.emplace_back(i, NumberLength(text, i));
      i += found.back().second;
    }
    return found;
  };
  auto strings_in = [&]() {
    std::vector<std::pair<size_t, size_t>> found;
    for (size_t open = text.find('"'); open != std::string::npos; open = text.find('"', open + 1)) {
      const size_t close = text.find_first_of("\"\n", open + 1);
      if (close == std::string::npos || text[close] != '"') continue;
      found.emplace_back(open, close - open + 1);
      open = close;
    }
    return found;
  };
  auto lines = [&]() {
    std::vector<std::pair<size_t, size_t>> out;
    size_t start = 0;
    while (start < text.size()) {
      const size_t end = text.find('\n', start);
      const size_t stop = end == std::string::npos ? text.size() : end + 1;
      out.emplace_back(start, stop - start);
      start = stop;
    }
    return out;
  };
  switch (kind) {
    case 0:
    case 1: {  // a number (the most common kind of field)
      const auto found = numbers_in();
      if (found.empty()) break;
      const auto [at, length] = found[pick(found.size())];
      const std::string value = numbers[pick(numbers.size())];
      text.replace(at, length, value);
      return {text, "number at " + std::to_string(at) + " -> " + value};
    }
    case 2: {  // a quoted string
      const auto found = strings_in();
      if (found.empty()) break;
      const auto [at, length] = found[pick(found.size())];
      const std::string value = strings[pick(strings.size())];
      text.replace(at, length, value);
      return {text, "string at " + std::to_string(at) + " -> " + value.substr(0, 20)};
    }
    case 3: {  // a line deleted
      const auto all = lines();
      const auto [at, length] = all[pick(all.size())];
      text.erase(at, length);
      return {text, "line at " + std::to_string(at) + " deleted"};
    }
    case 4: {  // a line doubled
      const auto all = lines();
      const auto [at, length] = all[pick(all.size())];
      text.insert(at, text.substr(at, length));
      return {text, "line at " + std::to_string(at) + " doubled"};
    }
    default: {  // cut short
      const size_t at = pick(text.size());
      text.resize(at);
      return {text, "cut at " + std::to_string(at)};
    }
  }
  return {text, "unchanged"};
}

struct Outcome {
  int code = -1;  // exit code, or -signal, or 999 for a hang
  std::string output;
};

Outcome RunCase(const fs::path& scenario, const fs::path& out, const fs::path& log) {
  const pid_t pid = fork();
  if (pid == 0) {
    setpgid(0, 0);  // its own group: a hang is killed with everything it started
    const std::string launch = std::string(COSIM_BIN_DIR) + "/cosim_launch";
    freopen(log.c_str(), "w", stdout);
    dup2(fileno(stdout), 2);
    execl(launch.c_str(), launch.c_str(), scenario.c_str(), "--out", out.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  const auto t0 = std::chrono::steady_clock::now();
  int status = 0;
  while (true) {
    const pid_t r = waitpid(pid, &status, WNOHANG);
    if (r == pid) break;
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > kWallLimit) {
      kill(-pid, SIGKILL);
      waitpid(pid, &status, 0);
      return {999, Slurp(log)};
    }
    usleep(10000);
  }
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status), Slurp(log)};
}

class Fuzz : public ::testing::TestWithParam<int> {};

TEST_P(Fuzz, EveryMutationEndsByTheRunContract) {
  const std::vector<fs::path> corpus = Corpus();
  ASSERT_GT(corpus.size(), 10u);
  const long total = EnvOr("COSIM_FUZZ_CASES", kBatches * kCasesPerBatch);
  const long seed = EnvOr("COSIM_FUZZ_SEED", 13);
  const long per_batch = (total + kBatches - 1) / kBatches;
  const fs::path dir = TempDir("fuzz_" + std::to_string(GetParam()));
  int codes[5] = {0, 0, 0, 0, 0};
  for (long k = GetParam() * per_batch; k < std::min(total, (GetParam() + 1) * per_batch); ++k) {
    std::mt19937_64 rng(static_cast<unsigned long long>(seed) * 1000003ULL + static_cast<unsigned long long>(k));
    const fs::path source = corpus[static_cast<size_t>(rng() % corpus.size())];
    const Mutation m = Mutate(Shorten(Slurp(source)), rng);
    const fs::path scenario = dir / ("case_" + std::to_string(k) + ".pbtxt");
    std::ofstream(scenario) << m.text;
    const fs::path out = dir / ("out_" + std::to_string(k));
    const Outcome o = RunCase(scenario, out, dir / ("log_" + std::to_string(k) + ".txt"));
    const std::string label = "case " + std::to_string(k) + " (seed " + std::to_string(seed) +
                              "): " + source.filename().string() + ", " + m.what;
    const bool contract = o.code == 0 || o.code == 2 || o.code == 3 || o.code == 4;
    EXPECT_TRUE(contract) << label << ": exit " << o.code << (o.code == 999 ? " (hang)" : "") << "\n" << o.output;
    if (contract) ++codes[o.code == 0 ? 0 : o.code];
    EXPECT_TRUE(fs::exists(out / "summary.json")) << label << ": no summary.json\n" << o.output;
    EXPECT_EQ(o.output.find("AddressSanitizer"), std::string::npos) << label << "\n" << o.output;
    EXPECT_EQ(o.output.find("runtime error:"), std::string::npos) << label << "\n" << o.output;  // UBSan
    EXPECT_EQ(o.output.find("internal error"), std::string::npos) << label << "\n" << o.output;
    // (The launcher turns a child's signal into exit 4: the signal is in its output.)
    EXPECT_EQ(o.output.find("was killed by signal"), std::string::npos) << label << "\n" << o.output;
    if (!HasFailure()) fs::remove_all(out);
  }
  std::printf("batch %d: exit 0: %d, 2: %d, 3: %d, 4: %d\n", GetParam(), codes[0], codes[2], codes[3], codes[4]);
}

INSTANTIATE_TEST_SUITE_P(Batches, Fuzz, ::testing::Range(0, kBatches));

}  // namespace
