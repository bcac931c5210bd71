#include "interface/scenario/coupling_plan.h"

#include <charconv>
#include <map>
#include <set>

#include "interface/base/errors.h"
#include "interface/scenario/checks.h"

namespace cosim::interface {

void CheckEndpoint(const Checks& checks, const std::string& path, const std::string& endpoint) {
  const std::string expected = " (expected tcp://HOST:PORT or ipc://PATH)";
  if (endpoint.rfind("ipc://", 0) == 0) {
    const std::string socket_path = endpoint.substr(6);
    if (socket_path.empty()) checks.Fail(path, "'" + endpoint + "' has no path" + expected);
    if (socket_path.size() > 107) {
      checks.Fail(path, "the ipc path has " + std::to_string(socket_path.size()) +
                            " bytes; a Unix socket's path holds at most 107 (sun_path): choose a shorter one");
    }
    return;
  }
  if (endpoint.rfind("tcp://", 0) == 0) {
    const std::string address = endpoint.substr(6);
    const size_t colon = address.rfind(':');
    const std::string host = colon == std::string::npos ? "" : address.substr(0, colon);
    const std::string port = colon == std::string::npos ? "" : address.substr(colon + 1);
    if (host.empty() || host == "*") {
      checks.Fail(path, "'" + endpoint +
                            "' names no host; both sides use the endpoint, so give the contact "
                            "process's host (e.g. tcp://127.0.0.1:5555)");
    }
    int number = 0;
    const auto [end, error] = std::from_chars(port.data(), port.data() + port.size(), number);
    if (port.empty() || error != std::errc() || end != port.data() + port.size() || number < 1 || number > 65535) {
      checks.Fail(path, "'" + endpoint + "': the port '" + port + "' is not a number in 1..65535");
    }
    return;
  }
  if (endpoint.rfind("inproc://", 0) == 0) {
    checks.Fail(path, "'" + endpoint +
                          "': inproc:// joins threads of one process; a contact process is another "
                          "process" +
                          expected);
  }
  checks.Fail(path, "'" + endpoint + "' is not a ZeroMQ endpoint this project uses" + expected);
}

ChannelTiming ReadChannelTiming(const ScenarioFile& file) {
  const Checks checks(file);
  const scenario::Coupling& coupling = file.proto().coupling();
  ChannelTiming timing;
  // ZeroMQ takes milliseconds as an int: 2147483 s at most; a week is more than any wait.
  timing.timeout = checks.InRange("coupling.timeout", true, coupling.timeout(), 0.0, 1e6, /*lo_open=*/true);
  timing.heartbeat = coupling.has_heartbeat()
                         ? checks.InRange("coupling.heartbeat", true, coupling.heartbeat(), 0.0, 0.5 * timing.timeout,
                                          /*lo_open=*/true)
                         : 0.1 * timing.timeout;
  return timing;
}

const std::vector<std::string>& ContactPrograms() {
  static const std::vector<std::string> programs = {"nonsmooth_solver", "penalty_solver"};
  return programs;
}

std::vector<ContactProcessPlan> ReadCouplingPlan(const ScenarioFile& file) {
  const Checks checks(file);
  const scenario::Coupling& coupling = file.proto().coupling();
  const scenario::Model& model = file.proto().model();
  if (coupling.processes_size() == 0) {
    checks.Fail("coupling.processes",
                "a coupled run needs at least one contact process (name, and optionally "
                "program, endpoint and contact_nodes)");
  }
  std::set<std::string> model_nodes;
  for (const auto& n : model.contact_nodes()) model_nodes.insert(n.name());
  std::vector<ContactProcessPlan> plan;
  std::map<std::string, std::string> owner;  // contact node → process
  NameTable names(checks, "contact process");
  for (int i = 0; i < coupling.processes_size(); ++i) {
    const auto& p = coupling.processes(i);
    const std::string path = ElementPath("coupling.processes", i);
    ContactProcessPlan process;
    process.index = i;
    process.name = names.Declare(path + ".name", p.has_name() && !p.name().empty(), p.name());
    bool known = false;
    std::string programs;
    for (const std::string& program : ContactPrograms()) {
      known = known || program == p.program();
      programs += (programs.empty() ? "" : ", ") + program;
    }
    if (!known)
      checks.Fail(path + ".program", "unknown contact program '" + p.program() + "'; expected one of " + programs);
    process.program = p.program();
    process.endpoint = p.endpoint();
    if (p.has_endpoint()) CheckEndpoint(checks, path + ".endpoint", p.endpoint());
    for (int k = 0; k < p.contact_nodes_size(); ++k) {
      const std::string& node = p.contact_nodes(k);
      const std::string npath = ElementPath(path + ".contact_nodes", k);
      if (model_nodes.count(node) == 0) {
        std::string list;
        for (const auto& n : model_nodes) list += (list.empty() ? "" : ", ") + n;
        checks.Fail(npath, "no contact node named '" + node + "'; known: " + list);
      }
      auto [it, inserted] = owner.emplace(node, process.name);
      if (!inserted) checks.Fail(npath, "contact node '" + node + "' is already in process '" + it->second + "'");
      process.nodes.push_back(node);
    }
    plan.push_back(process);
  }
  if (plan.size() == 1 && plan[0].nodes.empty()) {
    for (const auto& n : model.contact_nodes()) plan[0].nodes.push_back(n.name());
    return plan;
  }
  for (int i = 0; i < model.contact_nodes_size(); ++i) {
    const std::string& node = model.contact_nodes(i).name();
    if (owner.count(node) == 0) {
      checks.Fail(ElementPath("model.contact_nodes", i),
                  "contact node '" + node +
                      "' is in no contact process; with several processes each lists its nodes "
                      "in coupling.processes[].contact_nodes");
    }
  }
  return plan;
}

const ContactProcessPlan& FindProcess(const std::vector<ContactProcessPlan>& plan, const std::string& name,
                                      const ScenarioFile& file) {
  std::string known;
  for (const ContactProcessPlan& p : plan) {
    if (p.name == name) return p;
    known += (known.empty() ? "" : ", ") + p.name;
  }
  throw InputError("command line: --process '" + name + "' is not a contact process of " + file.path() +
                   "; its processes: " + known);
}

}  // namespace cosim::interface
