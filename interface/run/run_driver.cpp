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

namespace sc = cosim::scenario;

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

namespace {

// What a run is made of before its first step.
struct RunSetup {
  std::unique_ptr<ScenarioFile> file;
  std::unique_ptr<Simulation> simulation;
  std::unique_ptr<RunOutput> output;
  TimeSpan span;
};

// Everything before the first step: load, validate, build. Bad input ends here with exit
// code 2; whatever stops the run here (bad input, an endpoint that cannot be bound: exit 4, a
// model too large for memory) ends it with its exit code and, given --out, a summary saying
// why. Returns 0 or that code.
int SetUp(const std::string& program, const CommandLine& cli, const SimulationFactory& factory,
          ScenarioView process_view, RunSetup* run) {
  auto fail_before_start = [&](ExitCode code, const std::string& what) {
    run->output.reset();  // (its lock released: the failure summary goes into the same folder)
    std::cerr << program << ": error: " << what << "\n";
    WriteFailureSummary(program, cli, code, what);
    return static_cast<int>(code);
  };
  try {
    const ScenarioView view = cli.process.empty() ? ScenarioView::kWhole : process_view;
    run->file = std::make_unique<ScenarioFile>(ScenarioFile::Load(cli.scenario, cli.sets, view));
    run->span = ValidateTimeSpan(*run->file);
    run->simulation = factory(*run->file, cli);
    run->output = std::make_unique<RunOutput>(cli.out.empty() ? DefaultOutFolder(*run->file) : cli.out,
                                              run->simulation->ProbeNames());
    run->simulation->BeginOutput(run->output->folder());
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
  return 0;
}

// The refusal of an output setting once the run's folder exists: said on stderr (with the
// scenario's place) and in the summary, exit code 2.
int RefuseOutputSetting(const std::string& program, const RunSetup& run, const std::string& path,
                        const std::string& message, const std::string& reason) {
  std::cerr << program << ": error: " << run.file->Where(path) << ": " << path << ": " << message << "\n";
  return static_cast<int>(run.output->Finish(ExitCode::kBadInput, reason));
}

// The history's row: every probe's value times its Probe.scale (1 for columns that are not
// scenario probes, e.g. a MODES table). A value that is no longer finite ends the run as a
// numerical failure (exit 3) before its row is written: "ok" with inf in a history is no
// result (observed: an initial joint coordinate of 1e308 ran to the end that way).
class ProbeRow {
 public:
  ProbeRow(const Simulation& simulation, size_t columns)
      : simulation_(simulation), names_(simulation.ProbeNames()), values_(columns), scale_(columns, 1.0) {}
  // output.probes[i].scale of the columns it names; the index of a zero scale, or -1.
  int ReadScales(const ScenarioFile& file) {
    const auto& probes = file.proto().output().probes();
    for (int i = 0; i < probes.size(); ++i) {
      if (probes[i].scale() == 0.0) return i;
      for (size_t c = 0; c < names_.size() && c < scale_.size(); ++c) {
        if (names_[c] == probes[i].name()) scale_[c] = probes[i].scale();
      }
    }
    return -1;
  }
  const std::vector<double>& Read() {
    simulation_.Probe(&values_);
    for (size_t c = 0; c < values_.size(); ++c) {
      values_[c] *= scale_[c];
      if (!std::isfinite(values_[c])) {
        throw NumericalError("probe '" + (c < names_.size() ? names_[c] : std::to_string(c)) + "' is " +
                             FormatNumber(values_[c]) +
                             ": the solution is no longer finite (an input too large, or the step too long)");
      }
    }
    return values_;
  }

 private:
  const Simulation& simulation_;
  const std::vector<std::string> names_;
  std::vector<double> values_, scale_;
};

// How the steps went.
struct StepsOutcome {
  long long accepted = 0;
  std::chrono::steady_clock::duration step_time{};
  ExitCode code = ExitCode::kOk;
  std::string reason;
};

// The steps, with a row every `every` steps and at the last, and a visual frame every
// `visual_every` (0: none) and at the last; a failure ends them with its code and reason.
StepsOutcome Steps(const RunSetup& run, int every, int visual_every, ProbeRow* row) {
  const TimeSpan& span = run.span;
  std::unique_ptr<VisualSeries> visual;
  auto draw = [&](double time) {
    VisualFrame frame;
    run.simulation->Visual(&frame);
    visual->Write(frame, time);
  };
  StepsOutcome out;
  try {
    run.simulation->Start();
    run.output->WriteRow(span.start, row->Read());
    if (visual_every > 0) {
      visual = std::make_unique<VisualSeries>(run.output->folder());
      draw(span.start);
    }
    for (long long k = 0; k < span.steps; ++k) {
      if (TerminationRequested())
        throw PeerError("terminated by a signal (the launcher stops a run whose other process failed)");
      const double t = span.TimeAt(k);
      const double h = span.TimeAt(k + 1) - t;
      const auto t0 = std::chrono::steady_clock::now();
      run.simulation->Step(t, h);
      out.step_time += std::chrono::steady_clock::now() - t0;
      ++out.accepted;
      if (out.accepted % every == 0 || out.accepted == span.steps) {
        run.output->WriteRow(span.TimeAt(out.accepted), row->Read());
      }
      if (visual && (out.accepted % visual_every == 0 || out.accepted == span.steps)) draw(span.TimeAt(out.accepted));
    }
  } catch (const Error& e) {
    out.code = e.code();
    out.reason = "step " + std::to_string(out.accepted + 1) + " from t = " + FormatNumber(span.TimeAt(out.accepted)) +
                 " s: " + e.what();
  } catch (const std::exception& e) {
    out.code = ExitCode::kNumericalFailure;
    out.reason = "step " + std::to_string(out.accepted + 1) + " from t = " + FormatNumber(span.TimeAt(out.accepted)) +
                 " s: unexpected error: " + e.what();
  }
  return out;
}

// After the steps: the simulation's own ending and outputs, the summary's statistics and the
// last log line; the run's exit code.
int Finish(const std::string& program, const RunSetup& run, StepsOutcome outcome,
           std::chrono::steady_clock::time_point wall_start) {
  Simulation& simulation = *run.simulation;
  RunOutput& output = *run.output;
  try {
    simulation.Finish(outcome.code, outcome.reason);
  } catch (const std::exception& e) {
    output.Log(program + ": note: " + e.what());
  }
  try {
    simulation.EndOutput();
  } catch (const Error& e) {
    output.Log(program + ": error: " + e.what());
    if (outcome.code == ExitCode::kOk) {
      outcome.code = e.code();
      outcome.reason = e.what();
    }
  }
  run::RunSummary& summary = output.summary();
  const double reached = run.span.TimeAt(outcome.accepted);
  summary.set_steps(static_cast<int>(outcome.accepted));
  summary.set_simulated_time(reached);
  summary.set_step_wall_time(Seconds(outcome.step_time));
  simulation.FillSummary(&summary);
  // Iteration statistics a solver does not report were not performed: write them as zeros
  // so every summary has the same fields.
  for (run::IterationStats* stats :
       {summary.mutable_newton_iterations(), summary.mutable_coupling_iterations(), summary.mutable_lcp_iterations()}) {
    if (!stats->has_total()) IterationCounter().Fill(stats);
  }
  summary.set_wall_time(Seconds(std::chrono::steady_clock::now() - wall_start));
  if (outcome.code != ExitCode::kOk) {
    output.Log(program + ": error: " + outcome.reason);
  } else {
    output.Log(program + ": done, " + std::to_string(outcome.accepted) + " steps to t = " + FormatNumber(reached) +
               " s in " + FormatNumber(summary.wall_time()) + " s");
  }
  return static_cast<int>(output.Finish(outcome.code, outcome.reason));
}

}  // namespace

int RunProgram(const std::string& program, int argc, char** argv, const SimulationFactory& factory,
               ScenarioView process_view) {
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
  RunSetup run;
  if (const int code = SetUp(program, cli, factory, process_view, &run); code != 0) return code;

  run::RunSummary& summary = run.output->summary();
  summary.set_program(program);
  summary.set_scenario(ScenarioName(*run.file));
  summary.set_scenario_file(cli.scenario);
  for (const auto& s : cli.sets) summary.add_overrides(s);
  for (const auto& w : run.file->warnings()) summary.add_warnings(w);
  summary.set_start_time(run.span.start);

  const sc::Output& output = run.file->proto().output();
  const int every = output.has_every() ? output.every() : 1;
  if (every < 1) {
    return RefuseOutputSetting(program, run, "output.every", "must be >= 1, got " + std::to_string(every),
                               "output.every must be >= 1");
  }
  run.output->Log(program + ": scenario '" + summary.scenario() + "', " + std::to_string(run.span.steps) +
                  " steps of " + FormatNumber(run.span.step) + " s, output in " + run.output->folder());
  ProbeRow row(*run.simulation, static_cast<size_t>(run.output->probe_count()));
  if (const int zero = row.ReadScales(*run.file); zero >= 0) {
    const std::string path = "output.probes[" + std::to_string(zero) + "].scale";
    return RefuseOutputSetting(program, run, path, "must be non-zero", path + " must be non-zero");
  }
  const int visual_every = output.visual().every();
  if (visual_every < 0) {
    return RefuseOutputSetting(program, run, "output.visual.every",
                               "must be >= 0 (0: no visual output), got " + std::to_string(visual_every),
                               "output.visual.every must be >= 0");
  }
  return Finish(program, run, Steps(run, every, visual_every, &row), wall_start);
}

}  // namespace cosim::interface
