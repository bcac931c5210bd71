#pragma once
// Which contact process integrates which contact nodes, checked once for all three readers of
// a coupled scenario: the launcher (which processes to start), smooth_solver (one channel per
// process, each with its interface points) and each contact process (its own nodes only).
//
// Rules: at least one process; names unique and non-empty; `program` one of the contact
// programs this project ships; with one process an empty `contact_nodes` means every contact
// node; with several, each lists its nodes and every contact node of the model is in exactly
// one list; endpoints (when given) as CheckEndpoint says. Violations throw InputError naming
// the field.
#include <string>
#include <vector>

#include "interface/scenario/checks.h"
#include "interface/scenario/scenario_file.h"

namespace cosim::interface {

struct ContactProcessPlan {
  std::string name;
  std::string program;   // executable name in the build's bin folder
  std::string endpoint;  // empty until the launcher sets one
  std::vector<std::string> nodes;
  int index = 0;  // in coupling.processes
};

// A contact process's endpoint: tcp://HOST:PORT with a port in 1..65535, or ipc://PATH with a
// path that fits sun_path (at most 107 bytes). inproc:// joins threads of one process, never
// two processes. InputError at `path` otherwise.
void CheckEndpoint(const Checks& checks, const std::string& path, const std::string& endpoint);

// coupling.timeout in (0, 1e6] s; coupling.heartbeat in (0, timeout/2], default timeout/10.
struct ChannelTiming {
  double timeout = 0.0;
  double heartbeat = 0.0;
};
ChannelTiming ReadChannelTiming(const ScenarioFile& file);

// The programs that speak the coupling protocol as a contact process (docs/protocol.md).
const std::vector<std::string>& ContactPrograms();

std::vector<ContactProcessPlan> ReadCouplingPlan(const ScenarioFile& file);

// The process named `name` (InputError naming --process if there is none).
const ContactProcessPlan& FindProcess(const std::vector<ContactProcessPlan>& plan, const std::string& name,
                                      const ScenarioFile& file);

}  // namespace cosim::interface
