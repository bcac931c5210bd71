#include "interface/scenario/coupling_plan.h"

#include <map>
#include <set>

#include "interface/run/errors.h"
#include "interface/scenario/checks.h"

namespace cosim::interface {

const std::vector<std::string>& ContactPrograms() {
  static const std::vector<std::string> programs = {"nonsmooth_solver", "penalty_solver"};
  return programs;
}

std::vector<ContactProcessPlan> ReadCouplingPlan(const ScenarioFile& file) {
  const Checks checks(file);
  const scenario::Coupling& coupling = file.proto().coupling();
  const scenario::Model& model = file.proto().model();
  if (coupling.processes_size() == 0) {
    checks.Fail("coupling.processes", "a coupled run needs at least one contact process (name, and optionally "
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
    if (!known) checks.Fail(path + ".program", "unknown contact program '" + p.program() + "'; expected one of " + programs);
    process.program = p.program();
    process.endpoint = p.endpoint();
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
                  "contact node '" + node + "' is in no contact process; with several processes each lists its nodes "
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
