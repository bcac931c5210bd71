#include "interface/launcher/launcher.h"

#include <fcntl.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#include <zmq.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "interface/base/errors.h"
#include "interface/base/input_file.h"
#include "interface/coupling/channel.h"
#include "interface/run/run_output.h"
#include "interface/scenario/checks.h"
#include "interface/scenario/coupling_plan.h"
#include "interface/visual/visual_frame.h"

extern char** environ;

namespace cosim::interface {

namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// A fresh CURVE key pair (Z85).
std::pair<std::string, std::string> CurveKeyPair() {
  char public_key[41], secret_key[41];
  if (zmq_curve_keypair(public_key, secret_key) != 0) {
    throw PeerError(std::string("cannot make the coupling's CURVE keys: ") + zmq_strerror(zmq_errno()) +
                    " (libzmq without CURVE support?)");
  }
  return {public_key, secret_key};
}

}  // namespace

PrivateFolder::PrivateFolder() {
  // /tmp rather than TMPDIR: an ipc path must fit sun_path (108 bytes).
  std::string pattern = "/tmp/cosim-XXXXXX";
  if (mkdtemp(pattern.data()) == nullptr) {
    throw PeerError(std::string("cannot make a private folder in /tmp for the coupling's sockets: ") +
                    std::strerror(errno));
  }
  path_ = pattern;
  chmod(path_.c_str(), S_IRWXU);  // mkdtemp's 0700 is masked by the umask; this is not
  // The janitor: `sh -c 'read _; rm -rf -- "$0"' FOLDER` reading a pipe whose write end only
  // this process holds (close-on-exec: the solvers do not inherit it). It is exec'd at once
  // (nothing but async-signal-safe calls between fork and exec) and ignores the signals a
  // terminal sends the whole group, so that it outlives the launcher it watches.
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) return;  // (no janitor: the destructor still cleans up)
  const pid_t pid = fork();
  if (pid == 0) {
    dup2(fds[0], STDIN_FILENO);  // (dup2 clears close-on-exec on the copy)
    const int null = open("/dev/null", O_WRONLY);
    if (null >= 0) {
      dup2(null, STDOUT_FILENO);
      dup2(null, STDERR_FILENO);
    }
    signal(SIGINT, SIG_IGN);
    signal(SIGTERM, SIG_IGN);
    signal(SIGHUP, SIG_IGN);
    execl("/bin/sh", "sh", "-c", "read _; rm -rf -- \"$0\"", pattern.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  close(fds[0]);
  if (pid < 0) {
    close(fds[1]);
    return;
  }
  janitor_pipe_ = fds[1];
  janitor_ = pid;
}

PrivateFolder::~PrivateFolder() {
  std::error_code ignored;
  std::filesystem::remove_all(path_, ignored);
  if (janitor_pipe_ >= 0) close(janitor_pipe_);  // the janitor finds the folder gone and ends
  if (janitor_ > 0) waitpid(janitor_, nullptr, 0);
}

std::vector<ProcessPlan> PlanProcesses(const ScenarioFile& file, const CommandLine& cli,
                                       const std::vector<std::string>& arguments, const std::string& ipc_folder) {
  const scenario::Model& model = file.proto().model();
  const bool smooth = model.bodies_size() > 0 || model.elastic_bodies_size() > 0 || model.beams_size() > 0;
  const bool contact = model.contact_nodes_size() > 0;
  if (!smooth && !contact) {
    file.Fail("model", "the scene has neither rigid/elastic bodies nor contact nodes; nothing to simulate");
  }
  const std::string out = cli.out.empty() ? DefaultOutFolder(file) : cli.out;
  if (!(smooth && contact)) {
    const std::string program = smooth ? "smooth_solver" : "nonsmooth_solver";
    return {ProcessPlan{program, arguments, out, program, {}}};
  }
  // A coupled run: the contact processes (they bind) and smooth_solver, the coordinator (it
  // connects), all with the endpoints; each contact process's outputs in a subfolder.
  const scenario::Coupling& coupling = file.proto().coupling();
  if (coupling.interface_nodes_size() == 0) {
    file.Fail("coupling.interface_nodes",
              "bodies and contact nodes together make a coupled run: tie contact nodes to body points with "
              "coupling.interface_nodes (or run the two parts as separate scenarios)");
  }
  const std::vector<ContactProcessPlan> processes = ReadCouplingPlan(file);
  ReadChannelTiming(file);  // refused here once rather than by every process
  // The coordinator connects to every contact process; each contact process binds its own
  // endpoint only (given every endpoint, N processes would each read and list N overrides).
  std::vector<std::string> smooth_args = arguments;
  auto endpoint_of = [&](const ContactProcessPlan& process) -> std::vector<std::string> {
    if (!process.endpoint.empty()) return {};
    const std::string endpoint = "ipc://" + ipc_folder + "/" + std::to_string(process.index) + ".ipc";
    return {"--set", "coupling.processes[" + std::to_string(process.index) + "].endpoint=\"" + endpoint + "\""};
  };
  for (const ContactProcessPlan& process : processes) {
    const std::vector<std::string> set = endpoint_of(process);
    smooth_args.insert(smooth_args.end(), set.begin(), set.end());
  }
  const auto [server_public, server_secret] = CurveKeyPair();
  const auto [client_public, client_secret] = CurveKeyPair();
  auto variable = [](const char* name, const std::string& value) { return std::string(name) + "=" + value; };
  std::vector<std::string> contact_environment{
      variable(kCurveServerPublic, server_public), variable(kCurveServerSecret, server_secret),
      variable(kCurveClientPublic, client_public), variable(kSupervisedVariable, "1")};
  // A contact process's LCPs are a few nodes' each: OpenBLAS's worker threads cannot help them,
  // and each spins on sched_yield for ~0.1 s of CPU after it starts (0.19 s of CPU for a
  // contact process's start and 2 s wait, 0.06 s with one thread; one process per blade on two
  // cores pays it once per blade). The user's own OPENBLAS_NUM_THREADS is kept.
  if (std::getenv("OPENBLAS_NUM_THREADS") == nullptr) contact_environment.emplace_back("OPENBLAS_NUM_THREADS=1");
  std::vector<ProcessPlan> plan;
  for (const ContactProcessPlan& process : processes) {
    std::vector<std::string> contact_args = arguments;
    const std::vector<std::string> set = endpoint_of(process);
    contact_args.insert(contact_args.end(), set.begin(), set.end());
    const std::string folder = out + "/" + process.name;
    contact_args.insert(contact_args.end(), {"--process", process.name, "--out", folder});
    plan.push_back(ProcessPlan{process.program, contact_args, folder, "contact process '" + process.name + "'",
                               contact_environment});
  }
  if (cli.out.empty()) smooth_args.insert(smooth_args.end(), {"--out", out});
  plan.push_back(ProcessPlan{"smooth_solver",
                             smooth_args,
                             out,
                             "smooth_solver",
                             {variable(kCurveServerPublic, server_public), variable(kCurveClientPublic, client_public),
                              variable(kCurveClientSecret, client_secret)}});
  return plan;
}

namespace {

struct Child {
  pid_t pid = -1;
  bool ended = false;
  int code = 0;             // the run contract's code (a signal: 4)
  int signal = 0;           // the signal that killed it, or 0
  bool terminated = false;  // SIGTERM sent
  Clock::time_point terminated_at;
  bool killed = false;                      // SIGKILL sent
  bool stopped = false;                     // stopped by a signal (SIGSTOP, SIGTSTP), not continued since
  int stopped_by = 0;                       // that signal
  Clock::time_point stopped_at;             // when the launcher saw it stop
  std::filesystem::file_time_type started;  // just before it was started (file clock)
};

// The time of the last row of a history.csv and the number of rows (0 if none).
std::pair<double, long> LastHistoryRow(const std::string& path) {
  const InputFile text = ReadInputFile(path, kMaxOutputBytes);  // (bounded: not a device's endless text)
  if (!text.ok()) return {0.0, 0};
  std::istringstream in(text.text);
  std::string line, last;
  long rows = -1;  // the header
  while (std::getline(in, line)) {
    if (!line.empty()) last = line;
    ++rows;
  }
  if (rows <= 0) return {0.0, 0};
  return {std::strtod(last.c_str(), nullptr), rows};
}

// The exit code a process wrote into its own summary, if it wrote one after `started` (it was
// killed while tearing down after its last word: its summary stands), or -1.
// (RunOutput removes an earlier run's summary when it starts; the time tells one left by a run
// before that point from this run's.)
int OwnSummaryCode(const ProcessPlan& p, std::filesystem::file_time_type started) {
  const std::string path = p.out + "/summary.json";
  std::error_code absent;
  const auto written = std::filesystem::last_write_time(path, absent);
  run::RunSummary s;
  if (absent || written < started || !ReadSummaryJson(path, &s) || s.program() != p.program) return -1;
  return s.exit_code();
}

// The summary of a process that a signal killed: it could not write one.
void WriteKilledSummary(const ProcessPlan& p, const CommandLine& cli, int signal, const std::string& why) {
  run::RunSummary s;
  s.set_program(p.program);
  s.set_scenario_file(cli.scenario);
  for (const auto& set : cli.sets) s.add_overrides(set);
  std::error_code absent;
  const bool started = std::filesystem::exists(p.out + "/history.csv", absent);
  const auto [time, rows] = LastHistoryRow(p.out + "/history.csv");
  s.set_simulated_time(time);
  s.set_status("failed");
  s.set_exit_code(static_cast<int>(ExitCode::kPeerFailure));
  s.set_reason(
      p.name + " was killed by signal " + std::to_string(signal) + " (" + strsignal(signal) + ")" + why +
      "; summary written by the launcher; " +
      (started ? "history.csv holds its rows up to t = " + FormatNumber(time) + " s (" + std::to_string(rows) + " rows)"
               : std::string("it was killed before its first output (while loading or building its "
                             "model, or making its output folder)")));
  WriteSummaryJson(s, p.out + "/summary.json");  // (its folder made if it died before making it)
}

// The run's summary (the coordinator's) says what a contact process that failed first said.
void PassContactFailureOn(const ProcessPlan& contact, int code, const ProcessPlan& coordinator) {
  run::RunSummary theirs, ours;
  const std::string contact_reason =
      ReadSummaryJson(contact.out + "/summary.json", &theirs) ? theirs.reason() : "(it wrote no summary)";
  const std::string path = coordinator.out + "/summary.json";
  if (!ReadSummaryJson(path, &ours)) ours.set_program(coordinator.program);
  if (ours.exit_code() == code) return;  // it ended on the contact process's own Shutdown: it says so
  const std::string own = ours.reason();
  ours.set_status("failed");
  ours.set_exit_code(code);
  ours.set_reason(contact.name + " (" + contact.program + ") failed with exit code " + std::to_string(code) + ": " +
                  contact_reason + (own.empty() ? "" : " [" + coordinator.program + ": " + own + "]"));
  WriteSummaryJson(ours, path);
}

}  // namespace

namespace {

// One history.csv: its header and its rows, cells as written (the time parsed too).
struct History {
  std::vector<std::string> header;
  std::vector<std::pair<double, std::vector<std::string>>> rows;
};

std::vector<std::string> SplitCells(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream in(line);
  std::string cell;
  while (std::getline(in, cell, ',')) cells.push_back(cell);
  return cells;
}

// Empty if the file is missing (a process that ended before writing it) or not a history (no
// `time` column first). A file that is not a regular file, or larger than a run writes, is
// refused (InputError naming it): read whole, /dev/full linked in its place filled the memory.
History ReadHistory(const std::string& path) {
  History h;
  std::error_code absent;
  if (!std::filesystem::exists(std::filesystem::symlink_status(path, absent))) return h;
  const InputFile text = ReadInputFile(path, kMaxOutputBytes);
  if (!text.ok()) throw InputError(text.why + "; expected the history.csv a process of this run wrote");
  std::istringstream in(text.text);
  std::string line;
  if (!std::getline(in, line)) return h;
  h.header = SplitCells(line);
  if (h.header.empty() || h.header[0] != "time") return {};
  while (std::getline(in, line)) {
    std::vector<std::string> cells = SplitCells(line);
    if (cells.size() != h.header.size()) break;  // a row cut short by a killed process
    char* end = nullptr;
    const double t = std::strtod(cells[0].c_str(), &end);
    if (end == cells[0].c_str()) break;
    h.rows.emplace_back(t, std::move(cells));
  }
  return h;
}

}  // namespace

void JoinHistories(const std::vector<std::pair<std::string, std::string>>& parts, const std::string& out) {
  std::vector<History> histories;
  std::vector<std::string> header{"time"};
  std::set<std::string> taken{"time"};
  for (const auto& [name, path] : parts) {
    History h = ReadHistory(path);
    if (h.header.empty()) continue;
    for (size_t c = 1; c < h.header.size(); ++c) {
      // A probe name seen already (two processes with a probe of the same name) takes its
      // process's name in front.
      std::string column = taken.count(h.header[c]) ? name + "/" + h.header[c] : h.header[c];
      taken.insert(column);
      header.push_back(column);
    }
    histories.push_back(std::move(h));
  }
  // Rows at the union of the times (equal doubles: every process computes start + k h alike);
  // a history without a row at a time leaves its cells empty there.
  std::map<double, std::vector<std::string>> rows;
  size_t first = 1;
  for (const History& h : histories) {
    const size_t width = h.header.size() - 1;
    for (const auto& [t, cells] : h.rows) {
      std::vector<std::string>& row = rows[t];
      if (row.empty()) row.assign(header.size(), "");
      row[0] = cells[0];
      std::copy(cells.begin() + 1, cells.end(), row.begin() + static_cast<std::ptrdiff_t>(first));
    }
    first += width;
  }
  // Whole or not at all (WriteWholeFile): a failure leaves no temporary and names the file.
  const WrittenFile written = WriteWholeFile(out, [&header, &rows](std::ostream& file) {
    for (size_t c = 0; c < header.size(); ++c) file << (c ? "," : "") << header[c];
    file << "\n";
    for (const auto& [t, row] : rows) {
      for (size_t c = 0; c < row.size(); ++c) file << (c ? "," : "") << row[c];
      file << "\n";
    }
  });
  if (!written.ok()) throw InputError(written.why);
}

namespace {

// Starts every process of the plan, in order, with `child_mask` as its signal mask (it survives
// exec); the children die with the launcher.
std::vector<Child> StartChildren(const std::string& bin_dir, const std::vector<ProcessPlan>& plan,
                                 const sigset_t& child_mask) {
  const pid_t launcher = getpid();
  std::vector<Child> children(plan.size());
  for (size_t i = 0; i < plan.size(); ++i) {
    const ProcessPlan& p = plan[i];
    const std::string path = bin_dir + "/" + p.program;
    std::vector<std::string> argv_storage{path};
    argv_storage.insert(argv_storage.end(), p.arguments.begin(), p.arguments.end());
    std::vector<char*> argv;
    for (auto& a : argv_storage) argv.push_back(a.data());
    argv.push_back(nullptr);
    // The launcher's environment without any coupling keys of its own, plus this child's.
    std::vector<std::string> env_storage;
    for (char** e = environ; *e != nullptr; ++e) {
      if (std::strncmp(*e, "COSIM_CURVE_", 12) != 0) env_storage.emplace_back(*e);
    }
    env_storage.insert(env_storage.end(), p.environment.begin(), p.environment.end());
    std::vector<char*> envp;
    for (auto& e : env_storage) envp.push_back(e.data());
    envp.push_back(nullptr);
    children[i].started = std::filesystem::file_time_type::clock::now();
    const pid_t pid = fork();
    if (pid < 0) throw PeerError("cannot start " + path + ": " + std::strerror(errno));
    if (pid == 0) {
      // Dies with the launcher, however the launcher ends (SIGTERM: it writes its outputs).
      prctl(PR_SET_PDEATHSIG, SIGTERM);
      if (getppid() != launcher) _exit(static_cast<int>(ExitCode::kPeerFailure));
      sigprocmask(SIG_SETMASK, &child_mask, nullptr);
      execve(path.c_str(), argv.data(), envp.data());
      std::fprintf(stderr, "cosim: cannot execute %s: %s\n", path.c_str(), std::strerror(errno));
      _exit(static_cast<int>(ExitCode::kPeerFailure));
    }
    children[i].pid = pid;
  }
  return children;
}

// The supervision of a run's processes until all have ended (see RunProcesses).
class Supervisor {
 public:
  Supervisor(const std::vector<ProcessPlan>& plan, std::vector<Child>* children, double stopped_limit)
      : plan_(plan), children_(*children), last_(plan.size() - 1), stopped_limit_(stopped_limit) {}

  // Runs until every child has ended; the signals in `watched` must be blocked.
  void Run(const sigset_t& watched) {
    while (!AllEnded()) {
      siginfo_t info;
      const timespec slice{0, 50'000'000};
      const int got = sigtimedwait(&watched, &info, &slice);
      if (got == SIGTERM || got == SIGINT || got == SIGHUP) {
        if (!stop_requested_) std::cerr << "cosim: " << strsignal(got) << ": stopping the run's processes\n";
        stop_requested_ = true;
      }
      Reap();
      if (stop_requested_) {
        for (Child& c : children_) Terminate(c);
      }
      StopFollowers();
      StopHungProcesses();
    }
  }
  int contact_failure() const { return contact_failure_; }
  size_t failed_contact() const { return failed_contact_; }

 private:
  bool AllEnded() const {
    return std::all_of(children_.begin(), children_.end(), [](const Child& c) { return c.ended; });
  }
  void Terminate(Child& c) {
    if (c.ended || c.terminated) return;
    kill(c.pid, SIGTERM);
    c.terminated = true;
    c.terminated_at = Clock::now();
  }
  // Whoever ended, stopped or continued since the last look.
  void Reap() {
    while (true) {
      int status = 0;
      const pid_t pid = waitpid(-1, &status, WNOHANG | WUNTRACED | WCONTINUED);
      if (pid <= 0) break;
      for (size_t i = 0; i < children_.size(); ++i) {
        if (children_[i].pid != pid) continue;
        if (WIFSTOPPED(status) || WIFCONTINUED(status)) {
          children_[i].stopped = WIFSTOPPED(status);
          children_[i].stopped_by = children_[i].stopped ? WSTOPSIG(status) : 0;
          children_[i].stopped_at = Clock::now();
        } else {
          Ended(i, status);
        }
      }
    }
  }
  void Ended(size_t i, int status) {
    Child& c = children_[i];
    c.ended = true;
    c.stopped = false;
    if (WIFEXITED(status)) {
      c.code = WEXITSTATUS(status);
    } else if (const int own = OwnSummaryCode(plan_[i], c.started); own >= 0) {
      c.code = own;  // its last word was said: the signal only cut its teardown short
      std::cerr << "cosim: " << plan_[i].program << " was killed by signal " << WTERMSIG(status)
                << " after it wrote its summary (exit " << own << "); that summary stands\n";
    } else {
      c.signal = WIFSIGNALED(status) ? WTERMSIG(status) : SIGKILL;
      c.code = static_cast<int>(ExitCode::kPeerFailure);  // a process of the run vanished
      std::cerr << "cosim: " << plan_[i].program << " was killed by signal " << c.signal << "\n";
    }
    if (i == last_) coordinator_ended_at_ = Clock::now();
    if (i != last_ && c.code != 0 && contact_failure_ == 0 && !children_[last_].ended) {
      contact_failure_ = c.code;
      failed_contact_ = i;
      contact_failed_at_ = Clock::now();
    }
  }
  // The processes that follow another's end.
  void StopFollowers() {
    // A contact process failed while the coordinator runs: the coordinator may be ending too
    // (it told the contact process to stop); give it half a second, then stop it.
    Child& coordinator = children_[last_];
    if (contact_failure_ != 0 && !coordinator.ended && SecondsSince(contact_failed_at_) > 0.5 &&
        !coordinator.terminated) {
      std::cerr << "cosim: " << plan_[failed_contact_].program << " failed (exit " << contact_failure_ << "); stopping "
                << plan_[last_].program << "\n";
      Terminate(coordinator);
    }
    // Contact processes end on the coordinator's Shutdown; one still running 2 s after the
    // coordinator ended (it failed before it could connect) is stopped.
    if (coordinator.ended && SecondsSince(coordinator_ended_at_) > 2.0) {
      for (size_t i = 0; i < last_; ++i) {
        if (!children_[i].ended && !children_[i].terminated) {
          std::cerr << "cosim: " << plan_[i].program << " still running after the coordinator ended; terminating it\n";
          Terminate(children_[i]);
        }
      }
    }
  }
  // A process stopped by a signal for longer than the limit is hung (a peer that has never heard
  // from it waits for ever: a contact process for its Hello); one that ignores SIGTERM (stopped,
  // hung in a system call) is killed.
  void StopHungProcesses() {
    for (size_t i = 0; i < children_.size(); ++i) {
      Child& c = children_[i];
      if (!c.ended && c.stopped && !c.terminated && SecondsSince(c.stopped_at) > stopped_limit_) {
        std::cerr << "cosim: " << plan_[i].program << " has been stopped (signal " << c.stopped_by << ") for "
                  << FormatNumber(stopped_limit_) << " s, twice coupling.timeout: treating it as hung; stopping it\n";
        Terminate(c);
      }
      if (c.ended || !c.terminated || c.killed || SecondsSince(c.terminated_at) < kGraceSeconds) continue;
      std::cerr << "cosim: " << plan_[i].program << " did not end " << kGraceSeconds
                << " s after SIGTERM (stopped or hung); killing it\n";
      kill(c.pid, SIGKILL);
      c.killed = true;
    }
  }

  const std::vector<ProcessPlan>& plan_;
  std::vector<Child>& children_;
  const size_t last_;  // the coordinator of a coupled run, or the only process
  const double stopped_limit_;
  bool stop_requested_ = false;
  int contact_failure_ = 0;  // the code of the contact process that failed first
  size_t failed_contact_ = 0;
  Clock::time_point contact_failed_at_, coordinator_ended_at_;
};

// A coupled run's visual output: scene.pvd, every process's series as a part of one scene
// (ParaView opens all of it at once), with whatever frames each wrote, failed run or not.
// (The error_code forms: an output path the processes refused, e.g. longer than PATH_MAX,
// must not turn their exit code 2 into the launcher's own failure.)
std::string WriteRunScene(const std::vector<ProcessPlan>& plan) {
  const ProcessPlan& coordinator = plan.back();
  std::error_code unreadable;
  if (plan.size() < 2 || !std::filesystem::exists(coordinator.out + "/visual.pvd", unreadable)) return {};
  std::vector<std::pair<std::string, std::string>> series;
  for (const ProcessPlan& p : plan) {
    const std::string pvd = p.out + "/visual.pvd";
    if (!std::filesystem::exists(pvd, unreadable)) continue;
    const std::string prefix = p.out == coordinator.out ? "" : std::filesystem::path(p.out).filename().string() + "/";
    series.emplace_back(prefix, pvd);
  }
  std::rotate(series.begin(), series.end() - 1, series.end());  // the smooth side first (part 0)
  try {
    WriteScenePvd(coordinator.out + "/scene.pvd", series);
  } catch (const Error& e) {
    return e.what();
  }
  return {};
}

// A coupled run's histories side by side (history_joined.csv): the coordinator's probes, then
// each contact process's, failed run or not. Returns why it could not be written, or "".
std::string JoinRunHistories(const std::vector<ProcessPlan>& plan) {
  if (plan.size() < 2) return {};
  const ProcessPlan& coordinator = plan.back();
  std::vector<std::pair<std::string, std::string>> parts{{coordinator.name, coordinator.out + "/history.csv"}};
  for (size_t i = 0; i + 1 < plan.size(); ++i) parts.emplace_back(plan[i].name, plan[i].out + "/history.csv");
  try {
    JoinHistories(parts, coordinator.out + "/history_joined.csv");
  } catch (const std::exception& e) {
    return std::string("the joined history was not written: ") + e.what();
  }
  return {};
}

// An output of a coupled run the launcher writes (the joined history, scene.pvd) that could not
// be: said, and a run that had ended ok ends 2 (the user guide lists them among its outputs), its
// summary saying why if it can be written.
int ReportLauncherOutput(const std::string& why, const ProcessPlan& coordinator, int code) {
  std::cerr << "cosim: " << why << "\n";
  if (code != 0) return code;
  run::RunSummary s;
  const std::string path = coordinator.out + "/summary.json";
  if (!ReadSummaryJson(path, &s)) s.set_program(coordinator.program);
  s.set_status("failed");
  s.set_exit_code(static_cast<int>(ExitCode::kBadInput));
  s.set_reason(why + (s.reason().empty() ? "" : " [" + s.reason() + "]"));
  WriteSummaryJson(s, path);
  return static_cast<int>(ExitCode::kBadInput);
}

}  // namespace

int RunProcesses(const std::string& bin_dir, const std::vector<ProcessPlan>& plan, const CommandLine& cli,
                 double stopped_limit) {
  // Everything the launcher waits for arrives as a signal, taken synchronously (sigtimedwait):
  // children ending, stopping or continuing (SIGCHLD) and requests to stop (SIGTERM, SIGINT,
  // SIGHUP).
  sigset_t watched, previous;
  sigemptyset(&watched);
  for (int s : {SIGCHLD, SIGTERM, SIGINT, SIGHUP}) sigaddset(&watched, s);
  sigprocmask(SIG_BLOCK, &watched, &previous);
  // The children start with SIGTERM, SIGINT and SIGHUP blocked (the mask survives exec) until
  // their run driver has installed its handler, so that stopping one that has only just
  // started still lets it write its outputs.
  sigset_t child_mask;
  sigemptyset(&child_mask);
  for (int s : {SIGTERM, SIGINT, SIGHUP}) sigaddset(&child_mask, s);
  std::vector<Child> children = StartChildren(bin_dir, plan, child_mask);
  Supervisor supervisor(plan, &children, stopped_limit);
  supervisor.Run(watched);
  sigprocmask(SIG_SETMASK, &previous, nullptr);

  // Summaries the processes could not write, and the run's when a contact process failed first.
  const size_t last = plan.size() - 1;
  for (size_t i = 0; i < children.size(); ++i) {
    if (children[i].signal == 0) continue;
    const std::string why =
        children[i].killed ? " (the launcher's, after it ignored SIGTERM for " + FormatNumber(kGraceSeconds) + " s)"
                           : "";
    WriteKilledSummary(plan[i], cli, children[i].signal, why);
  }
  const int contact_failure = supervisor.contact_failure();
  if (contact_failure != 0) PassContactFailureOn(plan[supervisor.failed_contact()], contact_failure, plan[last]);
  const std::string scene = WriteRunScene(plan), joined = JoinRunHistories(plan);
  int code = 0;
  if (contact_failure != 0) {
    code = contact_failure;
  } else if (children[last].code != 0) {
    code = children[last].code;
  } else {
    for (const Child& c : children) {
      if (c.code != 0 && code == 0) code = c.code;
    }
  }
  for (const std::string& why : {scene, joined}) {
    if (!why.empty()) code = ReportLauncherOutput(why, plan[last], code);
  }
  return code;
}

}  // namespace cosim::interface
