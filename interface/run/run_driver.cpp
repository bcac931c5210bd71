#include "interface/run/run_driver.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <iostream>
#include <limits>
#include <new>

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
    auto nonempty = [&](const std::string& flag, std::string v) {
      if (v.empty())
        throw InputError("command line: " + flag + " is given an empty string; expected " +
                         (flag == "--out" ? "a folder" : "a contact process name"));
      return v;
    };
    if (a == "--out") {
      cli.out = nonempty(a, value(a));
    } else if (a.rfind("--out=", 0) == 0) {
      cli.out = nonempty("--out", a.substr(6));
    } else if (a == "--process") {
      if (i + 1 >= arguments.size()) throw InputError("command line: --process needs a contact process name");
      cli.process = nonempty(a, arguments[++i]);
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

double TimeSpan::TimeAt(long long k) const { return k >= steps ? end : start + static_cast<double>(k) * step; }

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
    checks.Fail("numerics.end_time",
                "must be after start_time = " + FormatNumber(span.start) + " s, got " + FormatNumber(span.end));
  }
  span.step = checks.Positive("numerics.step", n.has_step(), n.step(), "s");
  const double count = (span.end - span.start) / span.step;
  if (count > 2e9) {
    checks.Fail("numerics.step", "gives " + FormatNumber(count) + " steps; more than 2e9 is not a sensible run");
  }
  // Times are doubles: far from 0 a step below their resolution does not advance the clock
  // (t + h == t). Ask for a thousandth of a step of resolution at the span's ends.
  const double resolution = std::numeric_limits<double>::epsilon() * std::max(std::abs(span.start), std::abs(span.end));
  if (span.step < 1e3 * resolution) {
    checks.Fail("numerics.step", FormatNumber(span.step) + " s is below what times of " +
                                     FormatNumber(std::max(std::abs(span.start), std::abs(span.end))) +
                                     " s resolve (1e3 × their spacing " + FormatNumber(resolution) +
                                     " s); move start_time nearer 0 or take a longer step");
  }
  // A last step shorter than 1e-9 of a step is merged away (round-off of end/step).
  span.steps = static_cast<long long>(std::ceil(count - 1e-9));
  if (span.steps < 1) span.steps = 1;
  return span;
}

std::string ScenarioName(const ScenarioFile& file) {
  if (!file.proto().name().empty()) return file.proto().name();  // checked when read
  // Unnamed: the file's stem, if it is a name (it becomes a folder name).
  const std::string stem = std::filesystem::path(file.path()).stem().string();
  try {
    return Checks(file).Name("name", true, stem);
  } catch (const InputError&) {
    return "run";
  }
}

std::string DefaultOutFolder(const ScenarioFile& file) { return "runs/" + ScenarioName(file); }

namespace {

double Seconds(std::chrono::steady_clock::duration d) { return std::chrono::duration<double>(d).count(); }

}  // namespace

void WriteFailureSummary(const std::string& program, const CommandLine& cli, ExitCode code, const std::string& reason) {
  if (cli.out.empty()) return;
  try {
    RunOutput failed(cli.out, {});
    failed.summary().set_program(program);
    failed.summary().set_scenario_file(cli.scenario);
    for (const auto& s : cli.sets) failed.summary().add_overrides(s);
    failed.Finish(code, reason);
  } catch (const Error&) {
    // The folder itself is the problem (or another run's); the caller has reported the error.
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

// NOLINTNEXTLINE(readability-function-size): over 120 lines; to be split along its seams
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
  // Whatever stops the run here (bad input, an endpoint that cannot be bound: exit 4, a model
  // too large for memory) ends it with its exit code and, given --out, a summary saying why.
  auto fail_before_start = [&](ExitCode code, const std::string& what) {
    output.reset();  // (its lock released: the failure summary goes into the same folder)
    std::cerr << program << ": error: " << what << "\n";
    WriteFailureSummary(program, cli, code, what);
    return static_cast<int>(code);
  };
  try {
    file = std::make_unique<ScenarioFile>(ScenarioFile::Load(cli.scenario, cli.sets));
    span = ValidateTimeSpan(*file);
    simulation = factory(*file, cli);
    output = std::make_unique<RunOutput>(cli.out.empty() ? DefaultOutFolder(*file) : cli.out, simulation->ProbeNames());
    simulation->BeginOutput(output->folder());
  } catch (const Error& e) {
    return fail_before_start(e.code(), e.what());
  } catch (const std::bad_alloc&) {
    return fail_before_start(ExitCode::kBadInput,
                             "the model does not fit in memory (out of memory while building "
                             "it); reduce its size");
  } catch (const std::exception& e) {
    return fail_before_start(ExitCode::kNumericalFailure,
                             std::string("unexpected error while building the model: ") + e.what());
  }

  run::RunSummary& summary = output->summary();
  summary.set_program(program);
  summary.set_scenario(ScenarioName(*file));
  summary.set_scenario_file(cli.scenario);
  for (const auto& s : cli.sets) summary.add_overrides(s);
  for (const auto& w : file->warnings()) summary.add_warnings(w);
  summary.set_start_time(span.start);

  const int every = file->proto().output().has_every() ? file->proto().output().every() : 1;
  if (every < 1) {
    std::cerr << program << ": error: " << file->Where("output.every") << ": output.every: must be >= 1, got " << every
              << "\n";
    return static_cast<int>(output->Finish(ExitCode::kBadInput, "output.every must be >= 1"));
  }

  output->Log(program + ": scenario '" + summary.scenario() + "', " + std::to_string(span.steps) + " steps of " +
              FormatNumber(span.step) + " s, output in " + output->folder());
  std::vector<double> values(static_cast<size_t>(output->probe_count()));
  // Each column's Probe.scale (1 for columns that are not scenario probes, e.g. a MODES table).
  std::vector<double> scale(values.size(), 1.0);
  {
    const std::vector<std::string> names = simulation->ProbeNames();
    const auto& probes = file->proto().output().probes();
    for (int i = 0; i < probes.size(); ++i) {
      if (probes[i].scale() == 0.0) {
        const std::string path = "output.probes[" + std::to_string(i) + "].scale";
        std::cerr << program << ": error: " << file->Where(path) << ": " << path << ": must be non-zero\n";
        return static_cast<int>(output->Finish(ExitCode::kBadInput, path + " must be non-zero"));
      }
      for (size_t c = 0; c < names.size() && c < scale.size(); ++c) {
        if (names[c] == probes[i].name()) scale[c] = probes[i].scale();
      }
    }
  }
  const std::vector<std::string> probe_names = simulation->ProbeNames();
  // A probe that is no longer finite ends the run as a numerical failure (exit 3) before its row
  // is written: "ok" with inf in a history is no result (observed: an initial joint coordinate of
  // 1e308 ran to the end that way).
  auto probe = [&]() {
    simulation->Probe(&values);
    for (size_t c = 0; c < values.size(); ++c) {
      values[c] *= scale[c];
      if (!std::isfinite(values[c])) {
        throw NumericalError("probe '" + (c < probe_names.size() ? probe_names[c] : std::to_string(c)) + "' is " +
                             FormatNumber(values[c]) +
                             ": the solution is no longer finite (an input too large, or the step too long)");
      }
    }
  };
  // output.visual: a frame every `visual_every` steps and at the last (interface/visual).
  const int visual_every = file->proto().output().visual().every();
  if (visual_every < 0) {
    std::cerr << program << ": error: " << file->Where("output.visual.every")
              << ": output.visual.every: must be >= 0 (0: no visual output), got " << visual_every << "\n";
    return static_cast<int>(output->Finish(ExitCode::kBadInput, "output.visual.every must be >= 0"));
  }
  std::unique_ptr<VisualSeries> visual;
  auto draw = [&](double time) {
    VisualFrame frame;
    simulation->Visual(&frame);
    visual->Write(frame, time);
  };
  long long accepted = 0;
  std::chrono::steady_clock::duration step_time{};
  ExitCode code = ExitCode::kOk;
  std::string reason;
  try {
    probe();
    output->WriteRow(span.start, values);
    if (visual_every > 0) {
      visual = std::make_unique<VisualSeries>(output->folder());
      draw(span.start);
    }
    for (long long k = 0; k < span.steps; ++k) {
      if (TerminationRequested())
        throw PeerError("terminated by a signal (the launcher stops a run whose other process failed)");
      const double t = span.TimeAt(k);
      const double h = span.TimeAt(k + 1) - t;
      const auto t0 = std::chrono::steady_clock::now();
      simulation->Step(t, h);
      step_time += std::chrono::steady_clock::now() - t0;
      ++accepted;
      if (accepted % every == 0 || accepted == span.steps) {
        probe();
        output->WriteRow(span.TimeAt(accepted), values);
      }
      if (visual && (accepted % visual_every == 0 || accepted == span.steps)) draw(span.TimeAt(accepted));
    }
  } catch (const Error& e) {
    code = e.code();
    reason =
        "step " + std::to_string(accepted + 1) + " from t = " + FormatNumber(span.TimeAt(accepted)) + " s: " + e.what();
  } catch (const std::exception& e) {
    code = ExitCode::kNumericalFailure;
    reason = "step " + std::to_string(accepted + 1) + " from t = " + FormatNumber(span.TimeAt(accepted)) +
             " s: unexpected error: " + e.what();
  }
  try {
    simulation->Finish(code, reason);
  } catch (const std::exception& e) {
    output->Log(program + ": note: " + e.what());
  }
  try {
    simulation->EndOutput();
  } catch (const Error& e) {
    output->Log(program + ": error: " + e.what());
    if (code == ExitCode::kOk) {
      code = e.code();
      reason = e.what();
    }
  }
  summary.set_steps(static_cast<int>(accepted));
  summary.set_simulated_time(span.TimeAt(accepted));
  summary.set_step_wall_time(Seconds(step_time));
  simulation->FillSummary(&summary);
  // Iteration statistics a solver does not report were not performed: write them as zeros
  // so every summary has the same fields.
  for (run::IterationStats* stats :
       {summary.mutable_newton_iterations(), summary.mutable_coupling_iterations(), summary.mutable_lcp_iterations()}) {
    if (!stats->has_total()) IterationCounter().Fill(stats);
  }
  summary.set_wall_time(Seconds(std::chrono::steady_clock::now() - wall_start));
  if (code != ExitCode::kOk) {
    output->Log(program + ": error: " + reason);
  } else {
    output->Log(program + ": done, " + std::to_string(accepted) + " steps to t = " +
                FormatNumber(span.TimeAt(accepted)) + " s in " + FormatNumber(summary.wall_time()) + " s");
  }
  return static_cast<int>(output->Finish(code, reason));
}

}  // namespace cosim::interface
