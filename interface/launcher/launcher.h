#pragma once
// The launcher behind `scripts/cosim run`: decides from the scenario which processes a run
// needs, starts them with the same command line, supervises them and passes their exit
// status on; it writes the run's summary where a process could not (killed by a signal) or
// where another process's failure is the run's (a contact process that refused its part).
#include <sys/types.h>

#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "interface/run/run_driver.h"
#include "interface/scenario/scenario_file.h"

namespace cosim::interface {

// Writes `out`, the histories `parts` (a name for clashes, a history.csv path) side by side: a
// `time` column at the union of their times, then each one's probe columns (a name already used
// gets "NAME/" in front), cells left empty where a history has no row. Missing or malformed
// histories are left out.
void JoinHistories(const std::vector<std::pair<std::string, std::string>>& parts, const std::string& out);

struct ProcessPlan {
  std::string program;                   // executable name, next to cosim_launch
  std::vector<std::string> arguments;    // after the program name
  std::string out;                       // its output folder
  std::string name;                      // for messages: the program, or the contact process's name
  std::vector<std::string> environment;  // NAME=VALUE added to (and replacing) the launcher's
};

// A folder only this user can enter (mode 0700 whatever the umask), for a coupled run's ipc
// sockets; removed with everything in it when the object goes — and, should the launcher be
// killed (SIGKILL: no destructor runs), by a janitor process that waits on a pipe from it and
// removes the folder when the pipe closes, whatever ended the launcher.
class PrivateFolder {
 public:
  PrivateFolder();  // PeerError if it cannot be made
  ~PrivateFolder();
  PrivateFolder(const PrivateFolder&) = delete;
  PrivateFolder& operator=(const PrivateFolder&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  int janitor_pipe_ = -1;  // the write end; the janitor's stdin is the read end
  pid_t janitor_ = -1;
};

// Single-solver scenes run one process: contact nodes only -> nonsmooth_solver; rigid or
// elastic bodies only -> smooth_solver. A coupled scene (bodies, contact nodes and
// coupling.interface_nodes) runs its contact processes (`--process NAME`, outputs in
// OUT/NAME) and smooth_solver, the coordinator, last. Contact processes without an endpoint
// get ipc://FOLDER/<index>.ipc in `ipc_folder` (short: within sun_path's 108 bytes whatever
// the process names). Every coupled run gets a fresh CURVE key pair for the contact processes
// (servers) and one for the coordinator (client), in the children's environment only
// (docs/protocol.md, "Security"). Throws InputError for a scene with neither, or bodies and
// contact nodes not tied together.
std::vector<ProcessPlan> PlanProcesses(const ScenarioFile& file, const CommandLine& cli,
                                       const std::vector<std::string>& arguments, const std::string& ipc_folder);

// Starts every process and supervises them until all have ended:
// - a contact process that fails while the coordinator runs gets the coordinator stopped
//   (SIGTERM) at once; contact processes still running 2 s after the coordinator ended are
//   stopped; a process that has not ended `kGraceSeconds` after its SIGTERM (it is stopped,
//   or hung) is killed (SIGKILL): the launcher always returns;
// - SIGTERM, SIGINT and SIGHUP to the launcher are passed on to the children (SIGTERM), with
//   the same escalation; the children die with the launcher if it is killed (PR_SET_PDEATHSIG);
// - a process stopped by a signal (SIGSTOP, or SIGTSTP sent to it alone) for longer than
//   `stopped_limit` seconds is treated as hung and stopped the same way: a peer that never heard
//   from it would wait for it for ever (a contact process waits for the Hello without timeout);
//   a coupled run passes twice coupling.timeout, by which a peer that did hear from it has given
//   up. A whole run suspended from the terminal (^Z) stops the launcher as well and is resumed
//   with it;
// - a process killed by a signal gets a summary.json written for it (status failed, exit 4,
//   the signal, the time its history reached); a contact process that failed first makes the
//   run's (the coordinator's) summary say its exit code and reason.
// Returns the first failing contact process's code if it failed first, else the coordinator's
// (or the only process's) if it failed, else the first non-zero one (a signal counts as 4),
// or 0.
int RunProcesses(const std::string& bin_dir, const std::vector<ProcessPlan>& plan, const CommandLine& cli,
                 double stopped_limit = std::numeric_limits<double>::infinity());

constexpr double kGraceSeconds = 3.0;

}  // namespace cosim::interface
