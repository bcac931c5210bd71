#include "interface/launcher/launcher.h"

#include <sys/wait.h>
#include <csignal>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <iostream>

#include "interface/run/errors.h"
#include "interface/run/run_driver.h"
#include "interface/scenario/coupling_plan.h"

namespace cosim::interface {

std::vector<ProcessPlan> PlanProcesses(const ScenarioFile& file, const std::vector<std::string>& arguments) {
  const scenario::Model& model = file.proto().model();
  const bool smooth = model.bodies_size() > 0 || model.elastic_bodies_size() > 0;
  const bool contact = model.contact_nodes_size() > 0;
  if (!smooth && !contact) {
    file.Fail("model", "the scene has neither rigid/elastic bodies nor contact nodes; nothing to simulate");
  }
  if (smooth && contact) {
    // A coupled run: the contact process (it binds) and smooth_solver, the coordinator
    // (it connects), both with the endpoint; the contact process's outputs in a subfolder.
    const scenario::Coupling& coupling = file.proto().coupling();
    if (coupling.interface_nodes_size() == 0) {
      file.Fail("coupling.interface_nodes",
                "bodies and contact nodes together make a coupled run: tie contact nodes to body points with "
                "coupling.interface_nodes (or run the two parts as separate scenarios)");
    }
    const std::vector<ContactProcessPlan> processes = ReadCouplingPlan(file);
    const CommandLine cli = ParseCommandLine(arguments);
    std::string out = cli.out;
    if (out.empty()) out = "runs/" + (file.proto().name().empty() ? std::string("run") : file.proto().name());
    std::vector<std::string> common = arguments;
    for (const ContactProcessPlan& process : processes) {
      if (!process.endpoint.empty()) continue;
      // ipc paths are limited to ~100 characters: a short one, unique to this launch.
      const std::string endpoint = "ipc:///tmp/cosim-" + std::to_string(getpid()) + "-" + process.name + ".ipc";
      common.insert(common.end(), {"--set", "coupling.processes[" + std::to_string(process.index) + "].endpoint=\"" +
                                                endpoint + "\""});
    }
    std::vector<ProcessPlan> plan;
    for (const ContactProcessPlan& process : processes) {
      std::vector<std::string> contact_args = common;
      contact_args.insert(contact_args.end(), {"--process", process.name, "--out", out + "/" + process.name});
      plan.push_back(ProcessPlan{process.program, contact_args});
    }
    std::vector<std::string> smooth_args = common;
    if (cli.out.empty()) smooth_args.insert(smooth_args.end(), {"--out", out});
    plan.push_back(ProcessPlan{"smooth_solver", smooth_args});
    return plan;
  }
  return {ProcessPlan{smooth ? "smooth_solver" : "nonsmooth_solver", arguments}};
}

int RunProcesses(const std::string& bin_dir, const std::vector<ProcessPlan>& plan) {
  std::vector<pid_t> children;
  // The children start with SIGTERM and SIGINT blocked (the mask survives exec) until their run
  // driver has installed its handler, so that stopping one that has only just started still
  // lets it write its outputs.
  sigset_t termination, previous;
  sigemptyset(&termination);
  sigaddset(&termination, SIGTERM);
  sigaddset(&termination, SIGINT);
  sigprocmask(SIG_BLOCK, &termination, &previous);
  for (const ProcessPlan& p : plan) {
    const std::string path = bin_dir + "/" + p.program;
    std::vector<std::string> argv_storage{path};
    argv_storage.insert(argv_storage.end(), p.arguments.begin(), p.arguments.end());
    std::vector<char*> argv;
    for (auto& a : argv_storage) argv.push_back(a.data());
    argv.push_back(nullptr);
    const pid_t pid = fork();
    if (pid < 0) throw PeerError(std::string("cannot start ") + path + ": " + std::strerror(errno));
    if (pid == 0) {
      execv(path.c_str(), argv.data());
      std::fprintf(stderr, "cosim: cannot execute %s: %s\n", path.c_str(), std::strerror(errno));
      _exit(static_cast<int>(ExitCode::kPeerFailure));
    }
    children.push_back(pid);
  }
  sigprocmask(SIG_SETMASK, &previous, nullptr);
  // The last process is the coordinator of a coupled run (or the only one). Wait for whichever
  // ends first: a contact process that fails while the coordinator runs (its scenario part was
  // refused, its step failed before it could say so) gets the coordinator stopped (SIGTERM: it
  // ends as a peer failure, outputs kept) instead of left waiting out its coupling timeout.
  // Contact processes end on the coordinator's Shutdown; one still running 2 s after it (the
  // coordinator failed before it could connect) is terminated.
  auto status_code = [&](size_t i, int status) {
    if (WIFEXITED(status)) return WEXITSTATUS(status);
    if (WIFSIGNALED(status)) {
      std::cerr << "cosim: " << plan[i].program << " was killed by signal " << WTERMSIG(status) << "\n";
    }
    return static_cast<int>(ExitCode::kPeerFailure);  // a process of the run vanished
  };
  std::vector<int> codes(children.size(), 0);
  std::vector<bool> ended(children.size(), false);
  const size_t last = children.size() - 1;
  int contact_failure = 0;  // the code of the first contact process that failed first
  while (!ended[last]) {
    int status = 0;
    const pid_t pid = waitpid(-1, &status, 0);
    if (pid < 0) {
      if (errno == EINTR) continue;
      break;
    }
    for (size_t i = 0; i < children.size(); ++i) {
      if (children[i] != pid) continue;
      ended[i] = true;
      codes[i] = status_code(i, status);
      if (i != last && codes[i] != 0 && contact_failure == 0) {
        // The coordinator may be ending too (it told the contact process to stop): give it a
        // moment before stopping it.
        for (int tick = 0; tick < 10 && !ended[last]; ++tick) {
          int s = 0;
          const pid_t r = waitpid(children[last], &s, WNOHANG);
          if (r == children[last]) {
            ended[last] = true;
            codes[last] = status_code(last, s);
          } else {
            usleep(50000);
          }
        }
        if (!ended[last]) {
          contact_failure = codes[i];
          std::cerr << "cosim: " << plan[i].program << " failed (exit " << codes[i] << "); stopping "
                    << plan[last].program << "\n";
          kill(children[last], SIGTERM);
        }
      }
    }
  }
  for (size_t i = 0; i < last; ++i) {
    if (ended[i]) continue;
    int status = 0;
    for (int tick = 0; tick < 20 && !ended[i]; ++tick) {  // 2 s
      const pid_t r = waitpid(children[i], &status, WNOHANG);
      ended[i] = r == children[i] || (r < 0 && errno != EINTR);
      if (!ended[i]) usleep(100000);
    }
    if (!ended[i]) {
      std::cerr << "cosim: " << plan[i].program << " still running after the coordinator ended; terminating it\n";
      kill(children[i], SIGTERM);
      while (waitpid(children[i], &status, 0) < 0 && errno == EINTR) {
      }
      codes[i] = codes[last] != 0 ? codes[last] : static_cast<int>(ExitCode::kPeerFailure);
      continue;
    }
    codes[i] = status_code(i, status);
  }
  // A contact process that failed first says what happened to the run (e.g. 2: its part of the
  // scenario was refused); else the coordinator's code (e.g. 4 when a contact process died);
  // otherwise the first failure.
  if (contact_failure != 0) return contact_failure;
  if (codes.back() != 0) return codes.back();
  for (int code : codes) {
    if (code != 0) return code;
  }
  return 0;
}

}  // namespace cosim::interface
