#include "interface/launcher/launcher.h"

#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <iostream>

#include "interface/run/errors.h"

namespace cosim::interface {

std::vector<ProcessPlan> PlanProcesses(const ScenarioFile& file, const std::vector<std::string>& arguments) {
  const scenario::Model& model = file.proto().model();
  const bool smooth = model.bodies_size() > 0 || model.elastic_bodies_size() > 0;
  const bool contact = model.contact_nodes_size() > 0;
  if (!smooth && !contact) {
    file.Fail("model", "the scene has neither rigid/elastic bodies nor contact nodes; nothing to simulate");
  }
  if (smooth && contact) {
    file.Fail("model",
              "bodies together with contact nodes make a coupled run, which this build cannot launch yet "
              "(co-simulation is issue 6); run the smooth and the contact parts as separate scenarios");
  }
  return {ProcessPlan{smooth ? "smooth_solver" : "nonsmooth_solver", arguments}};
}

int RunProcesses(const std::string& bin_dir, const std::vector<ProcessPlan>& plan) {
  std::vector<pid_t> children;
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
  int result = 0;
  for (size_t i = 0; i < children.size(); ++i) {
    int status = 0;
    while (waitpid(children[i], &status, 0) < 0 && errno == EINTR) {
    }
    int code = 0;
    if (WIFEXITED(status)) {
      code = WEXITSTATUS(status);
    } else if (WIFSIGNALED(status)) {
      std::cerr << "cosim: " << plan[i].program << " was killed by signal " << WTERMSIG(status) << "\n";
      code = static_cast<int>(ExitCode::kNumericalFailure);
    }
    if (result == 0) result = code;
  }
  return result;
}

}  // namespace cosim::interface
