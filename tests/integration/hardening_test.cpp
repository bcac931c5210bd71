// End-to-end hardening (issue 13): the run contract — exit 0 ok, 2 bad input with the place,
// 3 numerical failure, 4 peer failure, outputs kept — under a hostile user and a failing
// machine: files that are not files, full disks, shared output folders, signals to each
// process, stopped processes, peers that are slow, silent or not ours. Each test names the
// defect it guards against.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/integration/launch.h"

namespace {

using namespace cosim::test;
using Clock = std::chrono::steady_clock;

const std::string kScenarios = std::string(COSIM_SOURCE_DIR) + "/scenarios";
const std::string kBall = kScenarios + "/bouncing_ball.pbtxt";
const std::string kTiedDrop = kScenarios + "/tied_drop.pbtxt";

double SecondsSince(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// A process started in the background: `cosim_launch ARGUMENTS` (or another executable of the
// build), its output to `log`.
struct Background {
  pid_t pid = -1;
  // Waits at most `seconds`; the exit code, or -signal if it was killed, or 999 if it is still
  // running (then it is killed).
  int Wait(double seconds) {
    const auto t0 = Clock::now();
    int status = 0;
    while (SecondsSince(t0) < seconds) {
      const pid_t r = waitpid(pid, &status, WNOHANG);
      if (r == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    kill(pid, SIGKILL);
    waitpid(pid, &status, 0);
    return 999;
  }
};

Background Start(const std::string& program, const std::vector<std::string>& arguments, const fs::path& log) {
  std::vector<std::string> storage{std::string(COSIM_BIN_DIR) + "/" + program};
  storage.insert(storage.end(), arguments.begin(), arguments.end());
  std::vector<char*> argv;
  for (auto& a : storage) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t pid = fork();
  if (pid == 0) {
    const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    dup2(fd, 1);
    dup2(fd, 2);
    execv(argv[0], argv.data());
    _exit(127);
  }
  return Background{pid};
}

// The pids of running processes whose command line contains `needle` (not this one).
std::vector<pid_t> FindProcesses(const std::string& needle) {
  std::vector<pid_t> out;
  for (const auto& entry : fs::directory_iterator("/proc")) {
    const std::string name = entry.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::string cmdline = Slurp(entry.path() / "cmdline");
    for (char& c : cmdline) {
      if (c == '\0') c = ' ';
    }
    const pid_t pid = std::stoi(name);
    if (pid != getpid() && cmdline.find(needle) != std::string::npos && cmdline.find("hardening_tests") == std::string::npos) {
      out.push_back(pid);
    }
  }
  return out;
}

// Waits until a process whose command line contains `needle` runs; its pid, or -1.
pid_t WaitForProcess(const std::string& needle, double seconds = 10.0) {
  const auto t0 = Clock::now();
  while (SecondsSince(t0) < seconds) {
    const auto found = FindProcesses(needle);
    if (!found.empty()) return found.front();
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return -1;
}

TEST(Hardening, ScenarioThatIsNotARegularFileIsRefusedWithoutBlocking) {
  // A FIFO without a writer blocked in open() for ever; /dev/zero was read until memory ran
  // out. Only regular files are read, with a size limit.
  const fs::path dir = TempDir("not_a_file");
  const fs::path fifo = dir / "scene.pbtxt";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const auto t0 = Clock::now();
  Result r = Launch(fifo.string() + " --out " + (dir / "a").string());
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("not a regular file"), std::string::npos) << r.output;
  r = Launch("/dev/zero --out " + (dir / "b").string());
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("/dev/zero: the scenario is not a regular file"), std::string::npos) << r.output;
  EXPECT_LT(SecondsSince(t0), 5.0);
  // A huge regular file (sparse: no disk used) is refused by its size.
  const fs::path big = dir / "big.pbtxt";
  { std::ofstream(big) << "name: \"x\""; }
  fs::resize_file(big, 1ULL << 30);
  r = Launch(big.string() + " --out " + (dir / "c").string());
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("1073741824 bytes; at most"), std::string::npos) << r.output;
}

TEST(Hardening, FullDiskEndsTheRunWithExitTwoNotOk) {
  // history.csv on a full disk lost every row with exit 0 and status "ok". /dev/full fails
  // every write with ENOSPC, as a full disk does.
  const fs::path out = TempDir("full_disk");
  fs::create_symlink("/dev/full", out / "history.csv");
  const Result r = Launch(kBall + " --out " + out.string() + " --set numerics.end_time=1");
  EXPECT_EQ(r.code, 2) << r.output;
  const cosim::run::RunSummary s = ReadSummary(out);
  EXPECT_EQ(s.status(), "failed");
  EXPECT_EQ(s.exit_code(), 2);
  EXPECT_NE(s.reason().find("history.csv failed: No space left on device"), std::string::npos) << s.reason();
}

TEST(Hardening, UnwritableSummaryIsAFailedRun) {
  // An unwritable summary.json printed an error and still exited 0.
  const fs::path out = TempDir("unwritable_summary");
  fs::create_directories(out / "summary.json");  // a folder where the file should go
  const Result r = Launch(kBall + " --out " + out.string() + " --set numerics.end_time=0.1");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("summary.json"), std::string::npos) << r.output;
}

TEST(Hardening, SecondRunIntoTheSameFolderIsRefused) {
  // Two runs given the same --out interleaved their rows in one history.csv and both exited 0.
  const fs::path dir = TempDir("same_out");
  const fs::path out = dir / "out";
  Background first = Start("cosim_launch", {kBall, "--out", out.string(), "--set", "numerics.end_time=1e6"},
                           dir / "first.txt");
  ASSERT_NE(WaitForProcess("nonsmooth_solver " + kBall + " --out " + out.string()), -1);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // it has locked its folder
  const Result second = Launch(kBall + " --out " + out.string() + " --set numerics.end_time=0.1");
  EXPECT_EQ(second.code, 2) << second.output;
  EXPECT_NE(second.output.find("the output folder is in use by another run"), std::string::npos) << second.output;
  kill(first.pid, SIGTERM);
  EXPECT_EQ(first.Wait(10.0), 4);
  // The first run's files are its own: every row has the first run's time grid.
  const cosim::run::RunSummary s = ReadSummary(out);
  EXPECT_EQ(static_cast<long>(ReadHistory(out / "history.csv").size()), s.steps() + 1);
}

}  // namespace
