#include "interface/run/run_driver.h"

#include <chrono>
#include <csignal>
#include <cmath>
#include <filesystem>
#include <iostream>

#include "interface/scenario/checks.h"

namespace cosim::interface {

std::string Usage(const std::string& program) {
  return "usage: " + program +
         " SCENARIO.pbtxt [--out DIR] [--set FIELD.PATH=VALUE]...\n"
         "  SCENARIO   scenario in protobuf text format (schema: proto/scenario.proto)\n"
         "  --out DIR  output folder (default: runs/<scenario name>)\n"
         "  --set P=V  override one field, e.g. --set numerics.step=0.001\n"
         "  --process NAME  serve as contact process NAME of a coupled run (nonsmooth_solver)\n";
}

CommandLine ParseCommandLine(const std::vector<std::string>& arguments) {
  CommandLine cli;
  for (size_t i = 0; i < arguments.size(); ++i) {
    const std::string& a = arguments[i];
    auto value = [&](const std::string& flag) -> std::string {
      if (i + 1 >= arguments.size()) throw InputError("command line: " + flag + " needs a value");
      return arguments[++i];
    };
    if (a == "--out") {
      cli.out = value(a);
    } else if (a.rfind("--out=", 0) == 0) {
      cli.out = a.substr(6);
      if (cli.out.empty()) throw InputError("command line: --out= needs a folder");
    } else if (a == "--process") {
      if (i + 1 >= arguments.size()) throw InputError("command line: --process needs a contact process name");
      cli.process = arguments[++i];
    } else if (a == "--set") {
      cli.sets.push_back(value(a));
    } else if (a.rfind("--set=", 0) == 0) {
      cli.sets.push_back(a.substr(6));
    } else if (!a.empty() && a[0] == '-') {
      throw InputError("command line: unknown option '" + a + "'");
    } else if (cli.scenario.empty()) {
      cli.scenario = a;
    } else {
      throw InputError("command line: one scenario expected, got a second one '" + a + "'");
    }
  }
  if (cli.scenario.empty()) throw InputError("command line: no scenario file given");
  return cli;
}

double TimeSpan::TimeAt(long long k) const {
  return k >= steps ? end : start + static_cast<double>(k) * step;
}

TimeSpan ValidateTimeSpan(const ScenarioFile& file) {
  const Checks checks(file);
  const scenario::Numerics& n = file.proto().numerics();
  checks.Require("numerics", file.proto().has_numerics(), "a numerics { end_time: ... step: ... } block");
  TimeSpan span;
  span.start = n.start_time();
  if (!std::isfinite(span.start)) checks.Fail("numerics.start_time", "must be a finite time [s]");
  checks.Require("numerics.end_time", n.has_end_time(), "the end time [s]");
  span.end = n.end_time();
  if (!(span.end > span.start) || !std::isfinite(span.end)) {
    checks.Fail("numerics.end_time", "must be after start_time = " + FormatNumber(span.start) + " s, got " +
                                         FormatNumber(span.end));
  }
  span.step = checks.Positive("numerics.step", n.has_step(), n.step(), "s");
  const double count = (span.end - span.start) / span.step;
  if (count > 2e9) {
    checks.Fail("numerics.step", "gives " + FormatNumber(count) + " steps; more than 2e9 is not a sensible run");
  }
  // A last step shorter than 1e-9 of a step is merged away (round-off of end/step).
  span.steps = static_cast<long long>(std::ceil(count - 1e-9));
  if (span.steps < 1) span.steps = 1;
  return span;
}

namespace {

std::string DefaultOutFolder(const ScenarioFile* file, const std::string& scenario_path) {
  std::string name = file != nullptr ? file->proto().name() : "";
  if (name.empty()) name = std::filesystem::path(scenario_path).stem().string();
  return "runs/" + name;
}

double Seconds(std::chrono::steady_clock::duration d) { return std::chrono::duration<double>(d).count(); }

}  // namespace

void WriteInputFailureSummary(const std::string& program, const CommandLine& cli, const std::string& reason) {
  if (cli.out.empty()) return;
  try {
    RunOutput failed(cli.out, {});
    failed.summary().set_program(program);
    failed.summary().set_scenario_file(cli.scenario);
    for (const auto& s : cli.sets) failed.summary().add_overrides(s);
    failed.Finish(ExitCode::kBadInput, reason);
  } catch (const Error&) {
    // The folder itself is the problem; the caller has reported the error.
  }
}

namespace {
volatile std::sig_atomic_t g_termination = 0;
extern "C" void OnTermination(int) { g_termination = 1; }
}  // namespace

void InstallTerminationHandler() {
  std::signal(SIGTERM, OnTermination);
  std::signal(SIGINT, OnTermination);
  // The launcher starts its children with these blocked: a request made before now is
  // delivered here.
  sigset_t termination;
  sigemptyset(&termination);
  sigaddset(&termination, SIGTERM);
  sigaddset(&termination, SIGINT);
  sigprocmask(SIG_UNBLOCK, &termination, nullptr);
}

bool TerminationRequested() { return g_termination != 0; }

int RunProgram(const std::string& program, int argc, char** argv, const SimulationFactory& factory) {
  const auto wall_start = std::chrono::steady_clock::now();
  InstallTerminationHandler();
  std::vector<std::string> arguments(argv + 1, argv + argc);
  if (!arguments.empty() && (arguments[0] == "--help" || arguments[0] == "-h")) {
    std::cout << Usage(program);
    return 0;
  }
  CommandLine cli;
  try {
    cli = ParseCommandLine(arguments);
  } catch (const InputError& e) {
    std::cerr << program << ": error: " << e.what() << "\n" << Usage(program);
    return static_cast<int>(ExitCode::kBadInput);
  }

  // Everything before the first step: load, validate, build. Bad input ends here with
  // exit code 2, and if an output folder can be made, with a summary that says why.
  std::unique_ptr<ScenarioFile> file;
  std::unique_ptr<Simulation> simulation;
  std::unique_ptr<RunOutput> output;
  TimeSpan span;
  try {
    file = std::make_unique<ScenarioFile>(ScenarioFile::Load(cli.scenario, cli.sets));
    span = ValidateTimeSpan(*file);
    simulation = factory(*file, cli);
    output = std::make_unique<RunOutput>(cli.out.empty() ? DefaultOutFolder(file.get(), cli.scenario) : cli.out,
                                         simulation->ProbeNames());
  } catch (const InputError& e) {
    std::cerr << program << ": error: " << e.what() << "\n";
    WriteInputFailureSummary(program, cli, e.what());
    return static_cast<int>(ExitCode::kBadInput);
  }

  run::RunSummary& summary = output->summary();
  summary.set_program(program);
  summary.set_scenario(file->proto().name().empty() ? std::filesystem::path(cli.scenario).stem().string()
                                                    : file->proto().name());
  summary.set_scenario_file(cli.scenario);
  for (const auto& s : cli.sets) summary.add_overrides(s);
  summary.set_start_time(span.start);

  const int every = file->proto().output().has_every() ? file->proto().output().every() : 1;
  if (every < 1) {
    std::cerr << program << ": error: " << file->Where("output.every")
              << ": output.every: must be >= 1, got " << every << "\n";
    output->Finish(ExitCode::kBadInput, "output.every must be >= 1");
    return static_cast<int>(ExitCode::kBadInput);
  }

  output->Log(program + ": scenario '" + summary.scenario() + "', " + std::to_string(span.steps) +
              " steps of " + FormatNumber(span.step) + " s, output in " + output->folder());
  std::vector<double> values(static_cast<size_t>(output->probe_count()));
  long long accepted = 0;
  std::chrono::steady_clock::duration step_time{};
  ExitCode code = ExitCode::kOk;
  std::string reason;
  try {
    simulation->Probe(&values);
    output->WriteRow(span.start, values);
    for (long long k = 0; k < span.steps; ++k) {
      if (TerminationRequested()) throw PeerError("terminated by a signal (the launcher stops a run whose other process failed)");
      const double t = span.TimeAt(k);
      const double h = span.TimeAt(k + 1) - t;
      const auto t0 = std::chrono::steady_clock::now();
      simulation->Step(t, h);
      step_time += std::chrono::steady_clock::now() - t0;
      ++accepted;
      if (accepted % every == 0 || accepted == span.steps) {
        simulation->Probe(&values);
        output->WriteRow(span.TimeAt(accepted), values);
      }
    }
  } catch (const Error& e) {
    code = e.code();
    reason = "step " + std::to_string(accepted + 1) + " from t = " + FormatNumber(span.TimeAt(accepted)) +
             " s: " + e.what();
  } catch (const std::exception& e) {
    code = ExitCode::kNumericalFailure;
    reason = "step " + std::to_string(accepted + 1) + " from t = " + FormatNumber(span.TimeAt(accepted)) +
             " s: unexpected error: " + e.what();
  }
  try {
    simulation->Finish(code, reason);
  } catch (const Error& e) {
    output->Log(program + ": note: " + e.what());
  }
  try {
    simulation->WriteFiles(output->folder());
  } catch (const Error& e) {
    output->Log(program + ": note: " + e.what());
  }
  summary.set_steps(static_cast<int>(accepted));
  summary.set_simulated_time(span.TimeAt(accepted));
  summary.set_step_wall_time(Seconds(step_time));
  simulation->FillSummary(&summary);
  // Iteration statistics a solver does not report were not performed: write them as zeros
  // so every summary has the same fields.
  for (run::IterationStats* stats : {summary.mutable_newton_iterations(), summary.mutable_coupling_iterations(),
                                     summary.mutable_lcp_iterations()}) {
    if (!stats->has_total()) IterationCounter().Fill(stats);
  }
  summary.set_wall_time(Seconds(std::chrono::steady_clock::now() - wall_start));
  if (code != ExitCode::kOk) {
    output->Log(program + ": error: " + reason);
  } else {
    output->Log(program + ": done, " + std::to_string(accepted) + " steps to t = " +
                FormatNumber(span.TimeAt(accepted)) + " s in " + FormatNumber(summary.wall_time()) + " s");
  }
  output->Finish(code, reason);
  return static_cast<int>(code);
}

}  // namespace cosim::interface
