// End-to-end hardening: the run contract — exit 0 ok, 2 bad input with the place,
// 3 numerical failure, 4 peer failure, outputs kept — under a hostile user and a failing
// machine: files that are not files, full disks, shared output folders, signals to each
// process, stopped processes, peers that are slow, silent or not ours. Each test names the
// defect it guards against.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/ptrace.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>
#include <zmq.hpp>

#include "coupling.pb.h"
#include "interface/coupling/channel.h"
#include "tests/integration/launch.h"

namespace {

using namespace cosim::test;
using Clock = std::chrono::steady_clock;

const std::string kScenarios = std::string(COSIM_SOURCE_DIR) + "/scenarios";
const std::string kBall = kScenarios + "/bouncing_ball.pbtxt";
const std::string kTiedDrop = kScenarios + "/tied_drop.pbtxt";

double SecondsSince(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// A process started in the background: `cosim_launch ARGUMENTS` (or another executable of the
// build, or one named by its absolute path), its output to `log`.
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

// `own_group`: the process leads a process group of its own (as a shell job does), which a
// signal to the group reaches with everything it starts.
Background Start(const std::string& program, const std::vector<std::string>& arguments, const fs::path& log,
                 bool own_group = false) {
  std::vector<std::string> storage{program.front() == '/' ? program : std::string(COSIM_BIN_DIR) + "/" + program};
  storage.insert(storage.end(), arguments.begin(), arguments.end());
  std::vector<char*> argv;
  for (auto& a : storage) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t pid = fork();
  if (pid == 0) {
    if (own_group) setpgid(0, 0);
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
    if (pid != getpid() && cmdline.find(needle) != std::string::npos &&
        cmdline.find("hardening_tests") == std::string::npos) {
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

// Waits until process `pid`'s state in /proc/PID/stat is `state` ('T': stopped); false if it
// ended or did not get there within `seconds`.
bool WaitForProcessState(pid_t pid, char state, double seconds = 10.0) {
  const auto t0 = Clock::now();
  while (SecondsSince(t0) < seconds) {
    const std::string stat = Slurp("/proc/" + std::to_string(pid) + "/stat");
    const size_t paren = stat.rfind(')');  // the command name may hold spaces and parentheses
    if (paren == std::string::npos || paren + 2 >= stat.size()) return false;
    if (stat[paren + 2] == state) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

// A long tied_drop run (1e4 s) through the launcher into `out`, its output in `out`.txt, with
// `sets` (FIELD=VALUE) added; it is stopped by the test.
Background StartLongTiedDrop(const fs::path& out, const std::vector<std::string>& sets = {}) {
  std::vector<std::string> arguments{kTiedDrop, "--out", out.string(), "--set", "numerics.end_time=1e4"};
  for (const std::string& set : sets) arguments.insert(arguments.end(), {"--set", set});
  return Start("cosim_launch", arguments, out.string() + ".txt");
}

// Waits until `out`/`file` (history.csv) has `rows` rows after its header; false after `seconds`.
bool WaitForHistoryRows(const fs::path& out, int rows, double seconds, const std::string& file = "history.csv") {
  const auto t0 = Clock::now();
  while (SecondsSince(t0) < seconds) {
    const std::string history = Slurp(out / file);
    if (std::count(history.begin(), history.end(), '\n') >= rows + 1) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

// Waits until no process of the run into `out` is left (the launcher's children end with it:
// PR_SET_PDEATHSIG); false after `seconds`.
bool WaitUntilRunGone(const fs::path& out, double seconds) {
  const auto t0 = Clock::now();
  while (!FindProcesses(out.string()).empty() && SecondsSince(t0) < seconds) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return FindProcesses(out.string()).empty();
}

// The pid of the run's coordinator (smooth_solver) or contact process (nonsmooth_solver) once it runs.
pid_t WaitForProgram(const std::string& program, const fs::path& out) {
  return WaitForProcess("/" + program + " " + kTiedDrop + " --out " + out.string());
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

TEST(Hardening, TheLaunchersJoinReadsOnlyTheRegularFilesTheRunWrote) {
  // After every coupled run the launcher read each process's history.csv whole to join them:
  // with OUT/history.csv linked to /dev/full (the smooth process then ends 2 at once, naming
  // it) the launcher read /dev/full into memory until it was killed; a contact folder's history
  // linked to /dev/zero (the process writes into it without error) likewise. Now each is
  // measured first and refused by what it is: exit 2, naming the file.
  const fs::path full = TempDir("join_full");
  fs::create_symlink("/dev/full", full / "history.csv");
  Result r = Launch(kTiedDrop + " --out " + full.string() + " --set numerics.end_time=0.05");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("'" + (full / "history.csv").string() + "' is a character device, not a regular file"),
            std::string::npos)
      << r.output;
  const fs::path zero = TempDir("join_zero");
  fs::create_directories(zero / "contacts");
  fs::create_symlink("/dev/zero", zero / "contacts" / "history.csv");
  r = Launch(kTiedDrop + " --out " + zero.string() + " --set numerics.end_time=0.05");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("the joined history was not written: '" + (zero / "contacts" / "history.csv").string() +
                          "' is a character device, not a regular file"),
            std::string::npos)
      << r.output;
  EXPECT_EQ(ReadSummary(zero).exit_code(), 2);
}

TEST(Hardening, ACoupledRunWhoseJoinedHistoryOrSceneCannotBeWrittenIsNotOk) {
  // A coupled run ended 0 "ok" without its joined history or scene.pvd when the launcher could
  // not write them (the name taken, the disk full at that moment), leaving .part files. The
  // The user guide lists both among a coupled run's outputs: exit 2 naming the file, no .part left.
  // The launcher writes each through NAME.part and a rename; /dev/full linked there fails every
  // write with ENOSPC, as a full disk does.
  for (const std::string name : {"history_joined.csv", "scene.pvd"}) {
    const fs::path out = TempDir("full_" + name);
    fs::create_symlink("/dev/full", out / (name + ".part"));
    const Result r =
        Launch(kTiedDrop + " --out " + out.string() + " --set numerics.end_time=0.05 --set output.visual.every=10");
    EXPECT_EQ(r.code, 2) << name << ": " << r.output;
    EXPECT_NE(r.output.find("cannot write " + (out / name).string()), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(fs::symlink_status(out / (name + ".part")))) << name;
    const cosim::run::RunSummary s = ReadSummary(out);
    EXPECT_EQ(s.status(), "failed") << name;
    EXPECT_NE(s.reason().find(name), std::string::npos) << s.reason();
  }
}

TEST(Hardening, ANewRunNeverRemovesAnotherRunsFolder) {
  // With run A's --out at P/visual (or P/scene.pvd), run B with --out P removed P/visual whole to
  // drop old frames: A ended 2 with its history gone. B now removes only the files a run of P
  // writes, and refuses to put its frames into a running run's folder.
  for (const std::string name : {"visual", "scene.pvd"}) {
    const fs::path p = TempDir("nested_" + name), a = p / name;
    Background first = StartLongTiedDrop(a);
    ASSERT_TRUE(WaitForHistoryRows(a, 1, 120.0)) << Slurp(a.string() + ".txt");
    Result second = Launch(kBall + " --out " + p.string() + " --set numerics.end_time=0.05");
    EXPECT_EQ(second.code, 0) << second.output;
    if (name == "visual") {
      second = Launch(kBall + " --out " + p.string() + " --set numerics.end_time=0.05 --set output.visual.every=1");
      EXPECT_EQ(second.code, 2) << second.output;
      EXPECT_NE(second.output.find("/visual, where this run's frames go, is the output folder of a running run"),
                std::string::npos)
          << second.output;
    }
    EXPECT_TRUE(fs::exists(a / "history.csv")) << name;
    const size_t rows = ReadHistory(a / "history.csv").size();
    kill(first.pid, SIGTERM);
    EXPECT_EQ(first.Wait(30.0), 4) << Slurp(a.string() + ".txt");
    EXPECT_EQ(ReadSummary(a).exit_code(), 4) << name;
    EXPECT_GE(ReadHistory(a / "history.csv").size(), rows) << name;
  }
  // An earlier run's frames are still dropped: only they.
  const fs::path q = TempDir("old_frames");
  ASSERT_EQ(Launch(kBall + " --out " + q.string() + " --set numerics.end_time=0.05 --set output.visual.every=1").code,
            0);
  std::ofstream(q / "visual" / "notes.txt") << "mine";
  ASSERT_EQ(Launch(kBall + " --out " + q.string() + " --set numerics.end_time=0.01").code, 0);
  EXPECT_FALSE(fs::exists(q / "visual" / "000000.vtu"));
  EXPECT_FALSE(fs::exists(q / "visual.pvd"));
  EXPECT_TRUE(fs::exists(q / "visual" / "notes.txt"));
}

TEST(Hardening, ASettleWithNothingToRestOnIsBadInput) {
  // tied_drop settled (a body on a tie to a contact node in mid-air: nothing holds either)
  // ended 3, "no static equilibrium (residual 9.81 after 0 Newton iterations)": a scene with no
  // rest to settle into is bad input for settle, named with what holds nothing.
  const fs::path out = TempDir("settle_in_mid_air");
  const Result r = Launch(kTiedDrop + " --out " + out.string() + " --set numerics.smooth.settle=true");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("numerics.smooth.settle: nothing holds the model at rest where it starts"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("contact nodes 'node' rest on no plane"), std::string::npos) << r.output;
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
  Background first =
      Start("cosim_launch", {kBall, "--out", out.string(), "--set", "numerics.end_time=1e6"}, dir / "first.txt");
  ASSERT_NE(WaitForProcess("nonsmooth_solver " + kBall + " --out " + out.string()), -1);
  ASSERT_TRUE(WaitForHistoryRows(out, 1, 120.0));  // it has locked its folder (then it writes rows)
  const Result second = Launch(kBall + " --out " + out.string() + " --set numerics.end_time=0.1");
  EXPECT_EQ(second.code, 2) << second.output;
  EXPECT_NE(second.output.find("the output folder is in use by another run"), std::string::npos) << second.output;
  kill(first.pid, SIGTERM);
  EXPECT_EQ(first.Wait(10.0), 4);
  // The first run's files are its own: every row has the first run's time grid.
  const cosim::run::RunSummary s = ReadSummary(out);
  EXPECT_EQ(static_cast<long>(ReadHistory(out / "history.csv").size()), s.steps() + 1);
}

// The launcher's socket folder, from its output.
std::string SocketFolder(const std::string& output) {
  const std::string tag = "coupling sockets in ";
  const size_t at = output.find(tag);
  if (at == std::string::npos) return "";
  const size_t start = at + tag.size();
  return output.substr(start, output.find(' ', start) - start);
}

TEST(Hardening, UnbindableEndpointEndsWithExitFourAndASummary) {
  // A contact endpoint that cannot be bound threw a PeerError out of the simulation factory,
  // where only InputError was caught: nonsmooth_solver aborted.
  const fs::path out = TempDir("unbindable");
  const Result r = Launch(kTiedDrop + " --out " + out.string() +
                          " --set 'coupling.processes[0].endpoint=\"ipc:///nonexistent_cosim_dir/x.ipc\"'");
  EXPECT_EQ(r.code, 4) << r.output;
  EXPECT_EQ(r.output.find("terminate called"), std::string::npos) << r.output;
  const cosim::run::RunSummary contact = ReadSummary(out / "contacts");
  EXPECT_EQ(contact.exit_code(), 4);
  EXPECT_NE(contact.reason().find("cannot bind endpoint 'ipc:///nonexistent_cosim_dir/x.ipc'"), std::string::npos)
      << contact.reason();
  EXPECT_EQ(ReadSummary(out).exit_code(), 4);  // the run's summary says what ended it
}

TEST(Hardening, LongProcessNameAndTheSocketFolder) {
  // A legal process name of 100 characters made the ipc path longer than sun_path: the contact
  // process aborted. The launcher's endpoints are short (a private folder, the process's
  // index); the folder is the user's alone (0700) while the run goes and gone after it (every
  // coupled run used to leave its socket file in /tmp).
  const fs::path out = TempDir("long_name");
  const std::string name(100, 'p');
  const Result r = Launch(kTiedDrop + " --out " + out.string() +
                          " --set numerics.end_time=0.2 --set coupling.processes[0].name=" + name);
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(ReadSummary(out / name).status(), "ok");
  const std::string folder = SocketFolder(r.output);
  ASSERT_FALSE(folder.empty()) << r.output;
  EXPECT_FALSE(fs::exists(folder)) << folder;
  // While a run goes: mode 0700 whatever the umask (here 0777 masks everything).
  const fs::path out2 = TempDir("socket_folder_mode");
  const mode_t old_mask = umask(0777);
  Background run = StartLongTiedDrop(out2);
  umask(old_mask);
  ASSERT_NE(WaitForProgram("smooth_solver", out2), -1);
  std::string running;
  for (int i = 0; i < 100 && SocketFolder(running).empty(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    running = Slurp(out2.string() + ".txt");
  }
  struct stat info {};
  ASSERT_EQ(stat(SocketFolder(running).c_str(), &info), 0) << running;
  EXPECT_EQ(info.st_mode & 0777, 0700u);
  kill(run.pid, SIGTERM);
  EXPECT_EQ(run.Wait(10.0), 4);
  EXPECT_FALSE(fs::exists(SocketFolder(running)));
}

TEST(Hardening, StoppedContactProcessDoesNotHangTheRun) {
  // A stopped (SIGSTOP) contact process: the coordinator gave up after coupling.timeout with
  // exit 4, then the launcher sent SIGTERM to the stopped process and waited for ever. It now
  // escalates to SIGKILL after a grace period and writes the killed process's summary.
  const fs::path out = TempDir("stopped_contact");
  Background run = StartLongTiedDrop(out, {"coupling.timeout=1"});
  const pid_t contact = WaitForProgram("nonsmooth_solver", out);
  ASSERT_NE(contact, -1);
  ASSERT_TRUE(WaitForHistoryRows(out / "contacts", 1, 120.0));  // stepping (a row written), not starting
  const auto t0 = Clock::now();
  kill(contact, SIGSTOP);
  EXPECT_EQ(run.Wait(20.0), 4);
  // timeout 1 s + 2 s for the contact process to follow the coordinator + 3 s of grace.
  EXPECT_LT(SecondsSince(t0), 9.0);
  EXPECT_EQ(ReadSummary(out).exit_code(), 4);
  const cosim::run::RunSummary killed = ReadSummary(out / "contacts");
  EXPECT_EQ(killed.exit_code(), 4);
  EXPECT_NE(killed.reason().find("was killed by signal 9"), std::string::npos) << killed.reason();
  EXPECT_NE(killed.reason().find("after it ignored SIGTERM"), std::string::npos) << killed.reason();
}

TEST(Hardening, ARunSuspendedForLongerThanItsTimeoutGoesOnWhenResumed) {
  // ^Z on a coupled run stops its whole process group (the launcher and every process it
  // started) and fg continues it. Each side's wait counted the stopped time as its peer's
  // silence: a run suspended for longer than coupling.timeout ended with exit 4 as soon as it was
  // resumed. A receive slice that overran by the time its process did not run now moves the
  // deadline by that time. Suspended here for 3 s with a 1 s timeout.
  const fs::path out = TempDir("suspended_run");
  Background run =
      Start("cosim_launch",
            {kTiedDrop, "--out", out.string(), "--set", "numerics.end_time=60", "--set", "coupling.timeout=1"},
            out.string() + ".txt", /*own_group=*/true);
  ASSERT_TRUE(WaitForHistoryRows(out, 2, 30.0)) << Slurp(out.string() + ".txt");
  ASSERT_EQ(kill(-run.pid, SIGSTOP), 0);
  std::this_thread::sleep_for(std::chrono::seconds(3));
  ASSERT_EQ(kill(-run.pid, SIGCONT), 0);
  EXPECT_EQ(run.Wait(60.0), 0) << Slurp(out.string() + ".txt");
  const cosim::run::RunSummary s = ReadSummary(out);
  EXPECT_EQ(s.status(), "ok") << s.reason();
  EXPECT_DOUBLE_EQ(s.simulated_time(), 60.0);
}

TEST(Hardening, StoppedCoordinatorDoesNotHangTheRun) {
  // The mirror case: the contact process gives up after coupling.timeout; the launcher stops
  // the coordinator (SIGTERM, then SIGKILL) and writes the run's summary for it.
  // (timeout 2 s: the handshake's margin on a loaded machine; the run still ends within 9 s.)
  const fs::path out = TempDir("stopped_coordinator");
  Background run = StartLongTiedDrop(out, {"coupling.timeout=2"});
  const pid_t coordinator = WaitForProgram("smooth_solver", out);
  ASSERT_NE(coordinator, -1);
  // Stopped mid-run: once rows after the first (written before the handshake) reached the disk
  // (a fixed sleep of 1.5 s stopped it, on a loaded machine, before its handshake was over).
  ASSERT_TRUE(WaitForHistoryRows(out, 2, 30.0)) << Slurp(out.string() + ".txt");
  const auto t0 = Clock::now();
  kill(coordinator, SIGSTOP);
  EXPECT_EQ(run.Wait(20.0), 4);
  EXPECT_LT(SecondsSince(t0), 9.0);
  const cosim::run::RunSummary s = ReadSummary(out);
  EXPECT_EQ(s.exit_code(), 4);
  EXPECT_NE(s.reason().find("smooth_solver was killed by signal 9"), std::string::npos) << s.reason();
  EXPECT_GT(s.simulated_time(), 0.0);  // its rows reached the disk before it was stopped
}

TEST(Hardening, ACoordinatorStoppedBeforeItsContactProcessHeardFromItDoesNotHangTheRun) {
  // Seen in CI: on a loaded machine the coordinator of the test above gave up on its Welcome
  // after coupling.timeout (1 s: the contact process had not started yet) and was stopped
  // (SIGSTOP) while its socket lingered. The contact process, which had never heard from it,
  // waited for the Hello for ever and the launcher for the coordinator: the run hung. Now the
  // launcher treats a process of the run stopped for twice coupling.timeout as hung: SIGTERM,
  // SIGKILL 3 s later, the contact process stopped 2 s after that.
  // Replayed by a coordinator that stops itself before its first instruction: a launcher copied
  // into a folder of its own finds there a `smooth_solver` that raises SIGSTOP on itself (and
  // would then exec the real one). The first replay stopped the coordinator from here once it
  // was seen running; on a loaded CI machine it had shaken hands and taken two steps by then,
  // its contact process timed out first, and the path under test was not taken.
  const fs::path out = TempDir("coordinator_stopped_early");
  const fs::path bin = TempDir("coordinator_stopped_early_bin");
  fs::copy_file(std::string(COSIM_BIN_DIR) + "/cosim_launch", bin / "cosim_launch",
                fs::copy_options::overwrite_existing);
  fs::create_symlink(std::string(COSIM_BIN_DIR) + "/nonsmooth_solver", bin / "nonsmooth_solver");
  {
    std::ofstream wrapper(bin / "smooth_solver");
    wrapper << "#!/bin/sh\nkill -STOP $$\nexec " << COSIM_BIN_DIR << "/smooth_solver \"$@\"\n";
  }
  fs::permissions(bin / "smooth_solver", fs::perms::owner_all);
  Background run =
      Start((bin / "cosim_launch").string(),
            {kTiedDrop, "--out", out.string(), "--set", "numerics.end_time=1e4", "--set", "coupling.timeout=1"},
            out.string() + ".txt");
  // Timed from the moment the coordinator is stopped (state T), not from the launcher's start,
  // which a loaded machine may delay.
  const pid_t coordinator = WaitForProcess((bin / "smooth_solver").string());
  ASSERT_NE(coordinator, -1) << Slurp(out.string() + ".txt");
  WaitForProcessState(coordinator, 'T', 5.0);  // (if it never stops, the run's end is timed from here)
  const auto t0 = Clock::now();
  EXPECT_EQ(run.Wait(20.0), 4) << Slurp(out.string() + ".txt");
  // 2 s stopped + 3 s of grace + 2 s for the contact process to follow + its SIGTERM.
  EXPECT_LT(SecondsSince(t0), 10.0);
  const cosim::run::RunSummary s = ReadSummary(out);
  EXPECT_EQ(s.exit_code(), 4);
  EXPECT_NE(s.reason().find("smooth_solver was killed by signal 9"), std::string::npos) << s.reason();
  EXPECT_NE(Slurp(out.string() + ".txt").find("smooth_solver has been stopped (signal 19)"), std::string::npos)
      << Slurp(out.string() + ".txt");
}

TEST(Hardening, SignalsToTheLauncherReachItsChildren) {
  // SIGTERM (or ^C) to cosim_launch ended it at once while its children ran on; a SIGKILLed
  // launcher left them orphaned. Now SIGTERM is passed on (the run ends with exit 4 and every
  // process's outputs), and the children die with a killed launcher (PR_SET_PDEATHSIG), still
  // writing their summaries.
  for (const int signal : {SIGTERM, SIGKILL}) {
    const fs::path out = TempDir("launcher_signal_" + std::to_string(signal));
    Background run = StartLongTiedDrop(out);
    ASSERT_NE(WaitForProgram("smooth_solver", out), -1);
    // Both stepping (a row of each on disk): a signal before the first step found steps() == 0
    // under load, where 300 ms were not enough.
    ASSERT_TRUE(WaitForHistoryRows(out, 1, 120.0));
    ASSERT_TRUE(WaitForHistoryRows(out / "contacts", 1, 120.0));
    kill(run.pid, signal);
    const int code = run.Wait(10.0);
    EXPECT_EQ(code, signal == SIGTERM ? 4 : -SIGKILL);
    EXPECT_TRUE(WaitUntilRunGone(out, 10.0)) << "children outlived the launcher (signal " << signal << ")";
    for (const fs::path& folder : {out, out / "contacts"}) {
      const cosim::run::RunSummary s = ReadSummary(folder);
      EXPECT_EQ(s.exit_code(), 4) << folder;
      EXPECT_GT(s.steps(), 0) << folder;
    }
  }
}

TEST(Hardening, KilledCoordinatorStillLeavesASummaryAndItsRecentRows) {
  // A coordinator killed by SIGKILL left no summary.json and lost up to 64 KiB of buffered
  // history rows. The launcher writes its summary; rows reach the disk at least every second.
  const fs::path out = TempDir("killed_coordinator");
  Background run = StartLongTiedDrop(out);
  const pid_t coordinator = WaitForProgram("smooth_solver", out);
  ASSERT_NE(coordinator, -1);
  // 200 rows on disk (0.2 s simulated) while it runs on: they reach the disk at least every
  // second, or this wait would not end (was: 2.5 s of wall time, too little under load).
  ASSERT_TRUE(WaitForHistoryRows(out, 200, 120.0));
  ASSERT_TRUE(WaitForHistoryRows(out, 11, 120.0, "coupling.csv"));
  kill(coordinator, SIGKILL);
  EXPECT_EQ(run.Wait(15.0), 4);
  const cosim::run::RunSummary s = ReadSummary(out);
  EXPECT_EQ(s.status(), "failed");
  EXPECT_NE(s.reason().find("smooth_solver was killed by signal 9"), std::string::npos) << s.reason();
  // The rows on disk before the kill are kept (none cut), and the summary the launcher wrote
  // ends where they end.
  const auto rows = ReadHistory(out / "history.csv");
  ASSERT_GE(rows.size(), 200u);
  EXPECT_GE(rows.back()[0], 0.199);
  EXPECT_NEAR(s.simulated_time(), rows.back()[0], 1e-12);
  const auto iterations = ReadHistory(out / "coupling.csv");  // streamed too
  EXPECT_GT(iterations.size(), 10u);
}

TEST(Hardening, ContactOnlyBadInputIsTheRunsExitCodeAndReason) {
  // A contact node mass of 0 is checked only by the contact process: it exits 2, and the run's
  // summary said exit 4 "terminated by a signal while waiting for Welcome".
  const fs::path out = TempDir("contact_bad_input");
  const Result r = Launch(kTiedDrop + " --out " + out.string() + " --set model.contact_nodes[0].mass=0");
  EXPECT_EQ(r.code, 2) << r.output;
  const cosim::run::RunSummary s = ReadSummary(out);
  EXPECT_EQ(s.exit_code(), 2);
  EXPECT_NE(s.reason().find("model.contact_nodes[0].mass"), std::string::npos) << s.reason();
}

TEST(Hardening, AStrangerOnTheMachineCannotEndARun) {
  // Over tcp anyone on the machine could talk to a contact process: one Shutdown from another
  // user ended the run. The launcher's CURVE keys make the contact process refuse a peer
  // without them at the handshake; the run goes on to exit 0.
  const fs::path out = TempDir("stranger");
  const int port = 20000 + getpid() % 20000;
  const std::string endpoint = "tcp://127.0.0.1:" + std::to_string(port);
  Background run =
      StartLongTiedDrop(out, {"numerics.end_time=4", "coupling.processes[0].endpoint=\"" + endpoint + "\""});
  ASSERT_NE(WaitForProgram("nonsmooth_solver", out), -1);
  ASSERT_TRUE(WaitForHistoryRows(out / "contacts", 1, 120.0));  // its socket bound (it steps)
  zmq::context_t context;
  zmq::socket_t stranger(context, zmq::socket_type::dealer);
  stranger.set(zmq::sockopt::linger, 200);
  stranger.connect(endpoint);
  cosim::coupling::Envelope stop;
  stop.set_protocol_version(cosim::coupling::PROTOCOL_VERSION_CURRENT);
  stop.set_sender("smooth_solver");
  stop.mutable_shutdown()->set_exit_code(0);
  for (int i = 0; i < 5; ++i) {
    (void)stranger.send(zmq::buffer(stop.SerializeAsString()), zmq::send_flags::dontwait);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  stranger.close();
  EXPECT_EQ(run.Wait(60.0), 0) << Slurp(out.string() + ".txt");
  EXPECT_NEAR(ReadSummary(out / "contacts").simulated_time(), 4.0, 1e-12);
}

// Runs `arguments` through the launcher into a fresh folder; the summary.
cosim::run::RunSummary RunTo(const std::string& name, const std::string& arguments, int expected_code) {
  const fs::path out = TempDir(name);
  const Result r = Launch(arguments + " --out " + out.string());
  EXPECT_EQ(r.code, expected_code) << r.output;
  return ReadSummary(out);
}

TEST(Hardening, ContactSolversRefuseNonsenseStates) {
  // Silent nonsense, each ended "ok" with exit 0: a node driven to non-finite positions by
  // finite but huge inputs (its history showed 1e303 m), and a step of 10 s that put the
  // bouncing ball 489 m through the floor (energy −1460 J). Both contact programs now check
  // their state after every step: finite, and no contact deeper than
  // numerics.nonsmooth.max_penetration.
  const fs::path dir = TempDir("nonsense_states");
  std::ofstream(dir / "free_fall.pbtxt") << "name: \"free_fall\"\n"
                                            "model { gravity: [0, 0, -1e308] contact_nodes { name: \"n\" mass: 1 "
                                            "position: [0, 0, 0] } }\n"
                                            "numerics { end_time: 10 step: 0.01 }\n";
  cosim::run::RunSummary s = RunTo("free_fall", (dir / "free_fall.pbtxt").string(), 3);
  EXPECT_NE(s.reason().find("contact node 'n' has a non-finite position or velocity"), std::string::npos) << s.reason();
  EXPECT_NEAR(s.simulated_time(), 1.79, 1e-9);  // ½ g t² passes 1.8e308 m at t = 1.8 s
  s = RunTo("ten_second_step", kBall + " --set numerics.step=10 --set numerics.end_time=100", 3);
  EXPECT_NE(s.reason().find("contact 'ball/ground' is 489.5"), std::string::npos) << s.reason();
  EXPECT_NE(s.reason().find("max_penetration = 0.1 m"), std::string::npos) << s.reason();
  EXPECT_EQ(s.steps(), 0);
  // The same scene at its own step stays well inside the limit (Moreau–Jean penetrates about
  // |v| h θ at an impact: 4.4 m/s × 5 ms / 2).
  s = RunTo("ball_ok", kBall, 0);
  EXPECT_LT(s.max_constraint_violation(), 0.02);
  EXPECT_GT(s.max_constraint_violation(), 0.0);
}

TEST(Hardening, PenaltySolverChecksItsStateToo) {
  // The check sits in the contact stepper itself, below either method: the penalty program
  // with a contact so soft that the ball settles about 1 m deep ((m g / K)^(2/3), K = 10)
  // fails at 0.1 m.
  const fs::path out = TempDir("penalty_nonsense");
  const std::string command = std::string(COSIM_BIN_DIR) + "/penalty_solver " + kBall + " --out " + out.string() +
                              " --set numerics.penalty.stiffness=10 > /dev/null 2>&1";
  const int status = std::system(command.c_str());
  EXPECT_EQ(WIFEXITED(status) ? WEXITSTATUS(status) : -1, 3);
  EXPECT_NE(ReadSummary(out).reason().find("through its obstacle"), std::string::npos) << ReadSummary(out).reason();
}

TEST(Hardening, AContactProcesssNumericalFailureIsTheRunsExitThree) {
  // The contact process's own numerical failure (exit 3) became exit 4 at the coordinator and
  // in `cosim run`. Here its penetration limit is set below what the tied drop's impact
  // penetrates (about 1 mm).
  const cosim::run::RunSummary s =
      RunTo("contact_exit_3", kTiedDrop + " --set numerics.nonsmooth.max_penetration=1e-6", 3);
  EXPECT_EQ(s.exit_code(), 3);
  EXPECT_NE(s.reason().find("'contacts' stopped (exit code 3)"), std::string::npos) << s.reason();
  EXPECT_NE(s.reason().find("contact 'node/floor' is"), std::string::npos) << s.reason();
  EXPECT_GT(s.steps(), 800);  // up to the impact at t = 0.83 s
}

TEST(Hardening, CoordinatorsNonFiniteReactionsAreItsOwnNumericalFailure) {
  // A huge but finite load gives infinite multipliers: the coordinator sent them, the peer
  // refused them, and the run ended as a peer failure. It is the coordinator's numerical
  // failure. (Gravity would drive the contact node through the floor first: here the load is
  // a force on the smooth body alone.)
  const cosim::run::RunSummary s = RunTo(
      "coordinator_inf",
      kTiedDrop +
          " --set 'model.forces=[{ name: \"push\" load { body: \"body\" force: [{ constant: 0 }, { constant: 0 }, "
          "{ constant: -1.7e308 }] } }]'",
      3);
  // (With the relaxation, CGα's Newton iteration cannot converge on it: that stops the step
  // before the reactions are sent; the check on them stands behind it. With interface Jacobians
  // the smooth side's pre-solve holds the body on its tie with a finite 1.7e308 N, which the
  // contact process's force law then overflows: its own numerical failure, exit 3 with its
  // node named — not a refused message, nor a peer failure.)
  EXPECT_EQ(s.exit_code(), 3);
  EXPECT_EQ(s.reason().find("coupling: Reactions"), std::string::npos) << s.reason();
  EXPECT_TRUE(s.reason().find("step 1 from t = 0 s: CGα") != std::string::npos ||
              s.reason().find("contact node 'node' has a non-finite position or velocity") != std::string::npos)
      << s.reason();
  const cosim::run::RunSummary relaxed =
      RunTo("coordinator_inf_relaxed",
            kTiedDrop +
                " --set coupling.iteration.interface_jacobians=false --set 'model.forces=[{ name: \"push\" load "
                "{ body: \"body\" force: [{ constant: 0 }, { constant: 0 }, { constant: -1.7e308 }] } }]'",
            3);
  EXPECT_EQ(relaxed.reason().find("'contacts' stopped"), std::string::npos) << relaxed.reason();
  EXPECT_NE(relaxed.reason().find("step 1 from t = 0 s: CGα"), std::string::npos) << relaxed.reason();
}

TEST(Hardening, ReactionToleranceBelowRoundOffDoesNotStallTheCoupling) {
  // tied_drop asks for reactions to 1e-9 relative; at h = 3e-4 s the stiff tie turns the
  // positions' round-off (5.6e-17 m between iterations) into ~1e-9 N of jitter in the smooth
  // side's reaction, and step 1542 stalled at a residual of 1.06e-9 N until the iteration
  // limit: exit 3. The test now lets a residual within the reaction's own jitter pass once
  // the kinematics are unchanged to round-off, and counts such steps.
  const fs::path out = TempDir("roundoff_stall");
  // (The relaxation's test; with interface Jacobians a force mismatch within the tie's stiffness
  // times the displacement tolerance passes by construction.)
  const Result r =
      Launch(kTiedDrop + " --out " + out.string() + " --set numerics.step=0.0003 --set numerics.end_time=0.6" +
             " --set coupling.iteration.interface_jacobians=false");
  ASSERT_EQ(r.code, 0) << r.output;
  const cosim::run::RunSummary s = ReadSummary(out);
  EXPECT_GT(s.counters().at("coupling_steps_at_roundoff"), 0.0);
  EXPECT_LE(s.coupling_iterations().max_per_step(), 10);
  // Still tied: the body and the node agree to the Newton tolerance at every step.
  const auto body = ReadHistory(out / "history.csv"), node = ReadHistory(out / "contacts" / "history.csv");
  ASSERT_EQ(body.size(), node.size());
  double worst = 0.0;
  for (size_t k = 0; k < body.size(); ++k) worst = std::max(worst, std::abs(body[k][1] - node[k][1]));
  EXPECT_LT(worst, 1e-10);
}

TEST(Hardening, FiveThousandFreeBodiesNeedNoDenseMatrix) {
  // The initial-state solve (KINSOL) used a dense N × N matrix: 5000 free rigid bodies made it
  // 90000² doubles (65 GB) and the run crashed. It is sparse (KLU) now, like every other solve.
  const fs::path dir = TempDir("many_bodies");
  std::ofstream scene(dir / "many.pbtxt");
  scene << "name: \"many_bodies\"\nmodel {\n  gravity: [0, 0, -9.81]\n";
  for (int i = 0; i < 5000; ++i) {
    scene << "  bodies { name: \"b" << i << "\" mass: 1 inertia: [0.01, 0.01, 0.01] position: [" << i << ", 0, 0] }\n";
  }
  scene << "}\nnumerics { end_time: 0.01 step: 0.005 }\n";
  scene.close();
  const auto t0 = Clock::now();
  const Result r = Launch((dir / "many.pbtxt").string() + " --out " + (dir / "out").string());
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_LT(SecondsSince(t0), 30.0);
  EXPECT_EQ(ReadSummary(dir / "out").steps(), 2);
}

TEST(Hardening, AnEarlierRunsSummaryDoesNotSpeakForAKilledOne) {
  // A solver killed outside a launcher cannot write its summary; an earlier run's summary.json
  // in the same folder then claimed "ok" for it. A run removes it when it starts.
  const fs::path out = TempDir("stale_summary");
  std::ofstream(out / "summary.json") << "{\"status\": \"ok\", \"reason\": \"an earlier run\"}";
  Background run = Start("nonsmooth_solver", {kBall, "--out", out.string(), "--set", "numerics.end_time=1e6"},
                         out.string() + ".txt");
  ASSERT_NE(WaitForProcess("/nonsmooth_solver " + kBall + " --out " + out.string()), -1);
  ASSERT_TRUE(WaitForHistoryRows(out, 1, 120.0));
  kill(run.pid, SIGKILL);
  EXPECT_EQ(run.Wait(10.0), -SIGKILL);
  EXPECT_FALSE(fs::exists(out / "summary.json"));
  EXPECT_GT(ReadHistory(out / "history.csv").size(), 0u);
}

TEST(Hardening, ExtremeLcpDataDoNotCrashSiconos) {
  // Found by the fuzz test under AddressSanitizer: a sliding block at 1e20 m/s made Siconos'
  // Lemke crash (SIGSEGV, which the launcher reported as exit 4). The LCP is now handed over
  // scaled by powers of two when its data leave 2^±40, and the friction step runs. (At 1e300 m/s
  // the block's kinetic energy is inf, which ends a run as a numerical failure (a non-finite probe),
  // before any step: 1e150, whose energy is finite, carries the extreme LCP now.)
  for (const std::string speed : {"1e20", "1e150"}) {
    const fs::path out = TempDir("extreme_lcp_" + speed);
    const Result r =
        Launch(kScenarios + "/sliding_block.pbtxt --out " + out.string() + " --set 'model.contact_nodes[0].velocity=[" +
               speed + ", 0, 0]' --set numerics.end_time=0.05");
    EXPECT_EQ(r.code, 0) << r.output;
    EXPECT_EQ(r.output.find("killed by signal"), std::string::npos) << r.output;
    EXPECT_EQ(ReadSummary(out).steps(), 50);  // 0.05 s at h = 1 ms
  }
  const fs::path out = TempDir("extreme_lcp_1e300");
  const Result r = Launch(kScenarios + "/sliding_block.pbtxt --out " + out.string() +
                          " --set 'model.contact_nodes[0].velocity=[1e300, 0, 0]' --set numerics.end_time=0.05");
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_NE(r.output.find("probe 'kinetic_energy' is inf"), std::string::npos) << r.output;
}

TEST(Hardening, ALauncherKilledWithSigkillLeavesNoSocketFolder) {
  // SIGKILL to `cosim run` left /tmp/cosim-XXXXXX/ and its ipc files behind
  // (6 of 6 tries): no destructor runs. Its janitor process removes the folder when the
  // launcher's pipe closes, however the launcher ended.
  const fs::path out = TempDir("sigkill_launcher");
  Background run = StartLongTiedDrop(out);
  ASSERT_NE(WaitForProgram("smooth_solver", out), -1);
  std::string log;
  for (int i = 0; i < 100 && SocketFolder(log).empty(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    log = Slurp(out.string() + ".txt");
  }
  const std::string folder = SocketFolder(log);
  ASSERT_EQ(folder.rfind("/tmp/cosim-", 0), 0u) << log;
  ASSERT_TRUE(fs::exists(folder));
  kill(run.pid, SIGKILL);
  EXPECT_EQ(run.Wait(10.0), -SIGKILL);
  const auto t0 = Clock::now();
  while (fs::exists(folder) && SecondsSince(t0) < 5.0) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_FALSE(fs::exists(folder)) << folder;
  // Its children end with it; until they have, they still write into `out`. Under load (two busy
  // processes beside the suite) they outlived this test, and removing the test's folder failed
  // ("Directory not empty").
  EXPECT_TRUE(WaitUntilRunGone(out, 10.0)) << "children outlived the launcher";
}

TEST(Hardening, ALargeRotorsNewtonFactorsGrowAsItsBladeCount) {
  // Issue 51, item 11: the Puma gust with 200 blades took 114 s for two steps, its Newton
  // matrix's LU factors growing faster than the model (L + U 0.63M, 1.56M and 4.36M entries for
  // 25, 50 and 100 blades with COLAMD, 1.7M, 5.1M and 16.8M with AMD: 2.5 and 3 times for twice
  // the blades). The hub's columns are now ordered last (hub_columns.h): 0.43M, 0.85M, 1.71M.
  // Here 16 and 32 blades, one co-simulated step each: twice the blades, at most 2.1 times the
  // factors (the pivots, chosen from the values, move the count by a few per cent).
  double fill[2] = {0.0, 0.0};
  for (int twice = 0; twice < 2; ++twice) {
    const int blades = 16 << twice;
    const fs::path out = TempDir("blades_" + std::to_string(blades));
    const Result r = Launch(kScenarios + "/puma/gust.pbtxt --out " + out.string() +
                            " --set patterns[0].count=" + std::to_string(blades) + " --set numerics.end_time=0.001");
    ASSERT_EQ(r.code, 0) << r.output;
    const cosim::run::RunSummary s = ReadSummary(out);
    ASSERT_EQ(s.counters().count("newton_factor_entries"), 1u);
    fill[twice] = s.counters().at("newton_factor_entries");
    ASSERT_GT(fill[twice], 0.0);
  }
  std::printf("Puma gust, Newton L + U entries: 16 blades %.0f, 32 blades %.0f\n", fill[0], fill[1]);
  EXPECT_LE(fill[1], 2.1 * fill[0]);
}

TEST(Hardening, AContactProcessUnderTheLauncherWaitsForAHelloAsLongAsItTakes) {
  // The Puma gust with 200 blades failed as "peer died" — its contact
  // processes waited coupling.timeout (10 s) for the Hello while the coordinator was still
  // building its model. Played here with a contact process and no coordinator, timeout 1 s:
  // started by the launcher (COSIM_SUPERVISED=1) it is still waiting after 3 s and ends at once
  // when the launcher stops it (SIGTERM, exit 4); started by hand it gives up after the timeout.
  const fs::path dir = TempDir("hello_wait");
  const std::string endpoint = "ipc://" + (dir / "c.ipc").string();
  auto start = [&](const std::string& name) {
    return Start("nonsmooth_solver",
                 {kTiedDrop, "--process", "contacts", "--out", (dir / name).string(), "--set",
                  "coupling.processes[0].endpoint=\"" + endpoint + "\"", "--set", "coupling.timeout=1"},
                 dir / (name + ".txt"));
  };
  setenv(cosim::interface::kSupervisedVariable, "1", 1);
  Background supervised = start("supervised");
  unsetenv(cosim::interface::kSupervisedVariable);
  std::this_thread::sleep_for(std::chrono::seconds(3));
  EXPECT_EQ(waitpid(supervised.pid, nullptr, WNOHANG), 0) << Slurp(dir / "supervised.txt");  // still waiting
  kill(supervised.pid, SIGTERM);
  EXPECT_EQ(supervised.Wait(3.0), 4) << Slurp(dir / "supervised.txt");
  Background by_hand = start("by_hand");
  EXPECT_EQ(by_hand.Wait(5.0), 4);
  EXPECT_NE(Slurp(dir / "by_hand.txt").find("no message from"), std::string::npos) << Slurp(dir / "by_hand.txt");
}

TEST(Hardening, ANewtonIterateWithNonFiniteMultipliersIsNotAStepsSolution) {
  // Found while measuring the Newton-matrix levers: the continuous Puma engagement at h = 2 ms with its
  // matrix reused over up to 80 steps ended with exit 3 at 26.408 s, "watchdog: non-finite
  // multipliers": Newton's test (|Δq| and |Φ|) had accepted an iterate of the stale matrix whose
  // multipliers were no longer finite. Such an iterate is now a failed solve, which the step
  // redoes with fresh matrices; the run ends at its end time (14.8 s of wall for 50 s here).
  const fs::path out = TempDir("stale_matrix_multipliers");
  const Result r = Launch(kScenarios + "/puma/engage_disengage_continuous.pbtxt --out " + out.string() +
                          " --set numerics.end_time=26.5 --set numerics.step=2e-3 --set output.every=25"
                          " --set numerics.smooth.jacobian_max_age=80");
  EXPECT_EQ(r.code, 0) << r.output;
  const cosim::run::RunSummary s = ReadSummary(out);
  EXPECT_EQ(s.exit_code(), 0) << s.reason();
  EXPECT_NEAR(s.simulated_time(), 26.5, 1e-9);
}

TEST(Hardening, AProcessKilledBeforeItMadeItsOutputFolderStillHasASummary) {
  // SIGTERM to `cosim run` while smooth_solver built a large model (the Puma
  // gust with many blades): the launcher killed it after the grace period and its summary had
  // no folder to go to — exit 4, "the run's outcome is lost", no output at all. The launcher now
  // makes the folder, and the summary says the process died before its first output.
  const fs::path out = TempDir("killed_while_building") / "run";
  const std::string scene = kScenarios + "/puma/gust_continuous.pbtxt";
  // An earlier run's "ok" in the folder does not speak for this one (the launcher takes a
  // killed process's own summary only if it was written after the process started).
  fs::create_directories(out);
  std::ofstream(out / "summary.json") << R"({"program": "smooth_solver", "status": "ok", "exit_code": 0})";
  fs::last_write_time(out / "summary.json", fs::file_time_type::clock::now() - std::chrono::hours(1));
  Background run =
      Start("cosim_launch", {scene, "--out", out.string(), "--set", "patterns[0].count=100"}, out.string() + ".txt");
  // The state the test needs is a solver that has not written its first output and does not
  // get to: it is stopped where it was found (a model this large takes longer to build than the
  // search for its process), so the launcher's SIGTERM waits and the grace period ends in SIGKILL,
  // as for a build longer than the grace period. (Waiting a fixed 300 ms instead failed in CI once
  // the hub ordering made this build fast enough to reach its first step within the grace period.)
  const pid_t solver = WaitForProcess("/smooth_solver " + scene);
  ASSERT_NE(solver, -1);
  ASSERT_EQ(kill(solver, SIGSTOP), 0);
  ASSERT_TRUE(WaitForProcessState(solver, 'T')) << "smooth_solver did not stop";
  ASSERT_FALSE(fs::exists(out / "history.csv")) << "the model was built already: the test plays nothing";
  kill(run.pid, SIGTERM);
  EXPECT_EQ(run.Wait(10.0), 4) << Slurp(out.string() + ".txt");
  const cosim::run::RunSummary s = ReadSummary(out);
  EXPECT_EQ(s.exit_code(), 4);
  EXPECT_NE(s.reason().find("killed before its first output"), std::string::npos) << s.reason();
  EXPECT_EQ(Slurp(out.string() + ".txt").find("outcome is lost"), std::string::npos);
}

// Runs the traced process `pid` (attached with PTRACE_SEIZE and PTRACE_O_TRACESYSGOOD) from
// system call to system call until `file` exists, and leaves it stopped there: true. False if it
// ended first.
bool StopOnceFileExists(pid_t pid, const fs::path& file) {
  while (true) {
    if (fs::exists(file)) return true;
    if (ptrace(PTRACE_SYSCALL, pid, nullptr, nullptr) != 0) return false;
    int status = 0;
    while (true) {
      if (waitpid(pid, &status, __WALL) != pid) return false;
      if (WIFEXITED(status) || WIFSIGNALED(status)) return false;
      if (WSTOPSIG(status) == (SIGTRAP | 0x80)) break;  // a system call's entry or exit
      // A signal on its way to the process: let it have it.
      if (ptrace(PTRACE_SYSCALL, pid, nullptr, reinterpret_cast<void*>(static_cast<long>(WSTOPSIG(status)))) != 0) {
        return false;
      }
    }
  }
}

TEST(Hardening, AContactProcessKilledInItsTeardownKeepsItsOwnSummary) {
  // A contact process killed after its complete run had written its summary
  // (exit 0, every step), while it tore down, turned the run into exit 4 and the launcher wrote
  // "killed by signal 9 … steps 0" over that summary. Played exactly: the test traces the
  // contact process's main thread from system call to system call, stops it at the first one
  // after its summary appears (the rename that publishes it), and kills it there. Its own summary
  // stands and the run's exit code agrees with OUT/summary.json. (Before, the test raced the
  // process to that moment from an inotify wake-up and, under load, lost 8 times in a row in one
  // run of four; traced, there is no race.)
  const fs::path out = TempDir("killed_in_teardown");
  Background run = Start("cosim_launch", {kTiedDrop, "--out", out.string(), "--set", "numerics.end_time=0.2"},
                         out.string() + ".txt");
  const pid_t contact = WaitForProgram("nonsmooth_solver", out);
  ASSERT_NE(contact, -1);
  ASSERT_EQ(ptrace(PTRACE_SEIZE, contact, nullptr, reinterpret_cast<void*>(PTRACE_O_TRACESYSGOOD)), 0)
      << "the test traces the contact process (ptrace): " << std::strerror(errno);
  // Stop it first (PTRACE_INTERRUPT), so that the system-call stepping starts from a stop.
  ASSERT_EQ(ptrace(PTRACE_INTERRUPT, contact, nullptr, nullptr), 0);
  int status = 0;
  ASSERT_EQ(waitpid(contact, &status, __WALL), contact);
  const bool stopped = StopOnceFileExists(contact, out / "contacts" / "summary.json");
  ASSERT_TRUE(stopped) << "the contact process ended before its summary appeared";
  kill(contact, SIGKILL);
  // The tracer is told first; then its parent, the launcher, learns of it.
  ASSERT_EQ(waitpid(contact, &status, __WALL), contact);
  EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) << "killed, after its summary: status " << status;
  const int code = run.Wait(20.0);
  const cosim::run::RunSummary mine = ReadSummary(out / "contacts");
  EXPECT_EQ(mine.exit_code(), 0) << mine.reason();
  EXPECT_GT(mine.steps(), 0);
  EXPECT_EQ(code, 0) << Slurp(out.string() + ".txt");
  EXPECT_EQ(ReadSummary(out).exit_code(), code);
}

}  // namespace
