// scripts/cosim study end to end on tiny scenes: the convergence study measures CGα's order on
// a closed-form oscillator and writes its CSV, plot and report; the stability study keeps going
// past a failing scene and reports it.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "tests/integration/launch.h"

namespace {

using namespace cosim::test;

const std::string kData = std::string(COSIM_SOURCE_DIR) + "/tests/data/study";

int Study(const std::string& arguments, const fs::path& log) {
  const std::string command = "/usr/bin/python3 " + std::string(COSIM_SOURCE_DIR) + "/scripts/study.py " + arguments +
                              " --bin " + std::string(COSIM_BIN_DIR) + " --jobs 2 > " + log.string() + " 2>&1";
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(Study, ConvergenceMeasuresOrderTwoOnTheOscillator) {
  // Five runs (h = 0.01 … 0.000625) against z = 0.1 cos 10t: CGα is second order (observed
  // 2.00), and the study leaves runs.csv, convergence.png and report.md.
  const fs::path out = TempDir("study_convergence");
  ASSERT_EQ(Study("convergence " + kData + "/oscillator.pbtxt --out " + out.string(), out / "log.txt"), 0)
      << Slurp(out / "log.txt");
  const Table runs = ReadTable(out / "runs.csv");
  ASSERT_EQ(runs.size(), 5u);
  EXPECT_TRUE(fs::exists(out / "convergence.png"));
  const std::string report = Slurp(out / "report.md");
  EXPECT_NE(report.find("fitted order"), std::string::npos);
  const std::vector<double> error = runs.Column("error_z");
  for (size_t k = 1; k < error.size(); ++k) EXPECT_NEAR(error[k - 1] / error[k], 4.0, 0.4) << k;
  EXPECT_NE(Slurp(out / "log.txt").find("[5/5]"), std::string::npos);  // progress was shown
}

TEST(Study, WorkPrecisionMeasuresEachMethodAgainstItsOwnReferenceAndNamesIt) {
  // The shipped pendulum's work-precision study (co-simulation and the monolithic twin, fixed
  // and adaptive steps) to its report. Seen when docs/results.md was regenerated: the runs had
  // become typed records but the report still read its reference runs as dicts, so the study
  // ended with a TypeError after every run had finished (no study test ran this kind).
  const fs::path out = TempDir("study_work_precision");
  ASSERT_EQ(
      Study("work-precision " + std::string(COSIM_SOURCE_DIR) + "/scenarios/pendulum_stop.pbtxt --out " + out.string(),
            out / "log.txt"),
      0)
      << Slurp(out / "log.txt");
  const std::string report = Slurp(out / "report.md");
  EXPECT_NE(report.find("'co-simulation (Moreau–Jean)': reference coupled, h = 1.5625e-5"), std::string::npos)
      << report;
  EXPECT_TRUE(fs::exists(out / "work_precision.png"));
  // Every fixed-step co-simulated run completes (the monolithic twin's largest steps may not:
  // exit 3). runs.csv: run,method,swept_value,exit,… (these rows' names have no comma).
  std::istringstream runs(Slurp(out / "runs.csv"));
  size_t cosimulated = 0;
  for (std::string line; std::getline(runs, line);) {
    if (line.rfind("co-simulation (Moreau–Jean) step=", 0) != 0) continue;
    ++cosimulated;
    std::vector<std::string> fields;
    std::istringstream cells(line);
    for (std::string cell; std::getline(cells, cell, ',');) fields.push_back(cell);
    ASSERT_GE(fields.size(), 4u) << line;
    EXPECT_EQ(fields[3], "0") << line;
  }
  EXPECT_GE(cosimulated, 5u);
}

TEST(Study, StabilityKeepsGoingPastAFailingScene) {
  const fs::path out = TempDir("study_stability");
  ASSERT_EQ(Study("stability " + kData + " --out " + out.string(), out / "log.txt"), 0) << Slurp(out / "log.txt");
  const std::string report = Slurp(out / "report.md");
  EXPECT_NE(report.find("| study_oscillator |"), std::string::npos) << report;
  EXPECT_NE(report.find("**no** (exit 2"), std::string::npos) << report;
  EXPECT_NE(report.find("numerics.step"), std::string::npos) << report;
}

TEST(Study, TimingRunsEachVariantAloneWithAndWithoutOutputAndRatesThePeer) {
  // Without `study.compare` the scene itself is timed: as written (a history row every step)
  // and without output (rows at the first and last step only), one run at a time. The ratio to
  // the peer is its wall time per simulated second over the run's: checked from the CSV's own
  // columns, so it holds whatever the machine's speed.
  const fs::path out = TempDir("study_timing");
  ASSERT_EQ(Study("timing " + kData + "/oscillator.pbtxt --out " + out.string() +
                      " --set study.peer.wall_time=3 --set study.peer.simulated_time=2",
                  out / "log.txt"),
            0)
      << Slurp(out / "log.txt");
  const Table timing = ReadTable(out / "timing.csv");
  ASSERT_EQ(timing.size(), 2u);
  const std::vector<double> wall = timing.Column("step_wall_time"), simulated = timing.Column("simulated_time"),
                            ratio = timing.Column("speed_ratio_to_peer"), steps = timing.Column("steps");
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(steps[k], 100.0);
    EXPECT_NEAR(simulated[k], 1.0, 1e-12);
    ASSERT_GT(wall[k], 0.0);
    EXPECT_NEAR(ratio[k], (3.0 / 2.0) / (wall[k] / simulated[k]), 1e-9 * ratio[k]);
  }
  EXPECT_EQ(ReadTable(out / "runs" / "r0_out" / "history.csv").size(), 101u);  // every step and t = 0
  EXPECT_EQ(ReadTable(out / "runs" / "r0_none" / "history.csv").size(), 2u);   // first and last
  const std::string report = Slurp(out / "report.md");
  EXPECT_NE(report.find("× faster than the peer"), std::string::npos) << report;
  // One run at a time: each progress line reports a batch of one.
  const std::string log = Slurp(out / "log.txt");
  EXPECT_EQ(log.find("[2/2]"), std::string::npos) << log;
  // A peer without a simulated time cannot be rated: refused, naming the field.
  EXPECT_EQ(Study("timing " + kData + "/oscillator.pbtxt --out " + out.string() + " --set study.peer.wall_time=3",
                  out / "log_bad.txt"),
            2);
  EXPECT_NE(Slurp(out / "log_bad.txt").find("study.peer"), std::string::npos);
}

TEST(Study, EnvelopeSweepsTwoAxesOnALocalClusterOfTwoWorkersAndKeepsFailedPoints) {
  // tests/data/envelope/pendulum.pbtxt: Hunt–Crossley stiffness (1e7, 1e8) × restitution
  // (0.5, 0.9, 1.5), six runs on a local Dask cluster of two workers, each shipped its scenario
  // folder and returning its outputs. Restitution 1.5 is bad input: those two runs fail with
  // exit 2 and stay rows of runs.csv. The measures hold for physical reasons: the 1 m rod's
  // tip cannot go below −1 m and reaches it where the stop is (vertical), 0.1 m above the
  // clearance plane; one impact in 0.7 s; and at equal impact speed and restitution a Hertzian
  // (exponent 1.5) contact's peak force scales as K^(2/5): ten times K, 10^0.4 = 2.51 times.
  const fs::path out = TempDir("study_envelope");
  ASSERT_EQ(
      Study("envelope " + std::string(COSIM_SOURCE_DIR) + "/tests/data/envelope/pendulum.pbtxt --out " + out.string(),
            out / "log.txt"),
      0)
      << Slurp(out / "log.txt");
  EXPECT_NE(Slurp(out / "log.txt").find("local Dask cluster (2 workers)"), std::string::npos) << Slurp(out / "log.txt");
  const Table runs = ReadTable(out / "runs.csv");
  ASSERT_EQ(runs.size(), 6u);
  const std::vector<double> k = runs.Column("stiffness"), e = runs.Column("restitution"), code = runs.Column("exit"),
                            lowest = runs.Column("tip_lowest"), clearance = runs.Column("clearance"),
                            force = runs.Column("peak_stop_force"), impacts = runs.Column("impacts");
  std::map<std::pair<double, double>, double> peak;
  for (size_t i = 0; i < runs.size(); ++i) {
    if (e[i] > 1.0) {
      EXPECT_EQ(code[i], 2.0) << i;
      continue;
    }
    EXPECT_EQ(code[i], 0.0) << i;
    EXPECT_NEAR(lowest[i], -1.0, 1e-4) << i;
    EXPECT_NEAR(clearance[i], 0.1, 1e-4) << i;
    EXPECT_EQ(impacts[i], 1.0) << i;
    peak[{k[i], e[i]}] = force[i];
  }
  for (double restitution : {0.5, 0.9}) {
    EXPECT_NEAR(peak.at({1e8, restitution}) / peak.at({1e7, restitution}), std::pow(10.0, 0.4), 0.03) << restitution;
  }
  EXPECT_TRUE(fs::exists(out / "envelope.png"));
  EXPECT_TRUE(fs::exists(out / "runs" / "p0" / "history.csv"));  // outputs brought back from the workers
  const std::string report = Slurp(out / "report.md");
  EXPECT_NE(report.find("exit 2 (bad input)"), std::string::npos) << report;
}

TEST(Study, ACoSimulatedEnvelopeStartsEveryPointFromOneSavedStateContactProcessIncluded) {
  // tests/data/envelope/spinning_stop.pbtxt (the spinning pendulum striking a stop that turns with
  // its hub), study.restart_time 0.3 s: one run to 0.3 s, then both restitution points from its
  // states — the smooth solver's and the contact process's, shipped together to the Dask workers
  // — over [0.3, 0.8] s. Each point's history starts at 0.3 s; the tip reaches the axis (z = −1 m,
  // the rod's length) in the step of the exact impact at 0.55014 s, whatever the restitution;
  // and the stop's peak impulse grows as 1 + e (Newton's law on the same impact speed):
  // 1.8 / 1.5 = 1.2.
  const fs::path out = TempDir("study_envelope_restart");
  ASSERT_EQ(Study("envelope " + std::string(COSIM_SOURCE_DIR) + "/tests/data/envelope/spinning_stop.pbtxt --out " +
                      out.string(),
                  out / "log.txt"),
            0)
      << Slurp(out / "log.txt");
  EXPECT_TRUE(fs::exists(out / "runs" / "settle" / "stops" / "final_state.pb"));
  const Table runs = ReadTable(out / "runs.csv");
  ASSERT_EQ(runs.size(), 2u);
  const std::vector<double> code = runs.Column("exit"), lowest = runs.Column("tip_lowest"),
                            when = runs.Column("tip_lowest_time"), force = runs.Column("peak_stop_force");
  for (size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(code[i], 0.0);
    EXPECT_NEAR(lowest[i], -1.0, 1e-5);
    EXPECT_NEAR(when[i], 0.550144, 0.0005 + 1e-9);
    const Table history = ReadTable(out / "runs" / ("p" + std::to_string(i)) / "stops" / "history.csv");
    EXPECT_NEAR(history.Column("time").front(), 0.3, 1e-12);
  }
  EXPECT_NEAR(force[1] / force[0], 1.8 / 1.5, 1e-3);
  EXPECT_NE(Slurp(out / "report.md").find("Every run starts at t = 0.3 s from the state of one settling run"),
            std::string::npos);
}

TEST(Study, AnEnvelopeOverASettledSceneStartsEveryPointWhereTheSceneSettled) {
  // tests/data/envelope/settled_stop.pbtxt: a rod drawn with its tip 1 cm above a co-simulated
  // stop, settled onto it (numerics.smooth.settle), kicked up at 0.35 s; study.restart_time 0.3 s.
  // As a new user ran such an envelope, every point failed (exit 2: "a run from a saved state ...
  // is settled already") and the study ended 0; with `numerics.smooth.settle=false` in the
  // envelope's own `set` (of its runs only, the schema says) the settling run was unsettled too
  // and every point continued a rod still bouncing from its drop. The points now start from the
  // settled run's state, settle off, whatever the envelope's `set`: the tip rests on its plane
  // (z = −0.01 m) from 0.3 s to the kick.
  const std::string scene = std::string(COSIM_SOURCE_DIR) + "/tests/data/envelope/settled_stop.pbtxt";
  const auto window = [](const fs::path& out) {
    std::vector<double> z;
    const Table h = ReadTable(out / "runs" / "p0" / "stops" / "history.csv");
    const std::vector<double> t = h.Column("time"), tip = h.Column("tip_z");
    for (size_t i = 0; i < t.size(); ++i)
      if (t[i] < 0.35) z.push_back(tip[i]);
    return z;
  };
  const fs::path out = TempDir("study_envelope_settled");
  ASSERT_EQ(Study("envelope " + scene + " --out " + out.string(), out / "log.txt"), 0) << Slurp(out / "log.txt");
  for (double code : ReadTable(out / "runs.csv").Column("exit")) EXPECT_EQ(code, 0.0);
  const std::vector<double> rest = window(out);
  ASSERT_EQ(rest.size(), 50u);                        // 0.300 … 0.349
  for (double z : rest) EXPECT_NEAR(z, -0.01, 1e-6);  // on its plane (unsettled: −0.0099 and moving)
  EXPECT_NE(Slurp(out / "report.md").find("whose start was settled as the scene asks"), std::string::npos);
  // The envelope's own `set` switching the settle off reaches its points only: the same window.
  const fs::path off = TempDir("study_envelope_settled_off");
  ASSERT_EQ(Study("envelope " + scene + " --out " + off.string() +
                      " --set 'study.envelope.set=[\"numerics.smooth.settle=false\"]'",
                  off / "log.txt"),
            0)
      << Slurp(off / "log.txt");
  const std::vector<double> same = window(off);
  ASSERT_EQ(same.size(), rest.size());
  for (size_t i = 0; i < rest.size(); ++i) EXPECT_EQ(same[i], rest[i]) << i;
  // Settling again from the saved state is refused at every point: the study measured nothing and
  // ends 2, naming why (it ended 0).
  const fs::path again = TempDir("study_envelope_settled_again");
  EXPECT_EQ(Study("envelope " + scene + " --out " + again.string() +
                      " --set 'study.envelope.set=[\"numerics.smooth.settle=true\"]'",
                  again / "log.txt"),
            2);
  const std::string log = Slurp(again / "log.txt");
  EXPECT_NE(log.find("no point of the envelope completed (exits 2)"), std::string::npos) << log;
  EXPECT_NE(log.find("is settled already"), std::string::npos) << log;
}

TEST(Study, AnOperatingLimitsEnvelopeRepeatsEveryQuarterTurnAndShadesItsUnsafePoints) {
  // tests/data/envelope/deck_rotor.pbtxt: a stopped four-blade rotor on a still deck in a LINEAR
  // airwake, wind speed (10, 16, 30 m/s) × relative wind direction (every 45°, a compass axis),
  // each point settled in its wind. The setup is invariant under a quarter turn, so every
  // measure at ψ is the one at ψ + 90° (to the solves' tolerance; observed within 1e-15 m). At
  // 30 m/s the windward blade's lift outgrows its weight's moment and it rests against its
  // anti-flap stop (+10°: its centre 2.38 m above the deck against 1.75 m on the droop stop).
  // The settle's plain Newton iterations found no rest there (exit 3, and the test expected the
  // points failed); walking in pseudo-time it finds this one, and the run stays on it. The
  // diagram hatches the points whose clearance is below 0.1505 m (observed: 0.1491–0.1495 m with
  // the wind along a blade, 0.1509–0.1539 m between two), and the report counts them as runs.csv's
  // clearances do.
  const fs::path out = TempDir("study_operating_limits");
  ASSERT_EQ(
      Study("envelope " + std::string(COSIM_SOURCE_DIR) + "/tests/data/envelope/deck_rotor.pbtxt --out " + out.string(),
            out / "log.txt"),
      0)
      << Slurp(out / "log.txt");
  const Table runs = ReadTable(out / "runs.csv");
  ASSERT_EQ(runs.size(), 24u);
  const std::vector<double> speed = runs.Column("wind speed"), direction = runs.Column("relative wind direction"),
                            code = runs.Column("exit"), lowest = runs.Column("tip_lowest"),
                            clearance = runs.Column("clearance"), force = runs.Column("peak_stop_force");
  std::map<std::pair<double, double>, size_t> at;
  for (size_t i = 0; i < runs.size(); ++i) at[{speed[i], direction[i]}] = i;
  const std::vector<double> highest = runs.Column("tip_highest");
  int unsafe = 0;
  for (size_t i = 0; i < runs.size(); ++i) {
    EXPECT_EQ(code[i], 0.0) << speed[i] << " m/s, " << direction[i] << "°";
    if (speed[i] > 20.0) {
      EXPECT_GT(highest[i], 2.3) << direction[i] << "°";  // a blade up against its anti-flap stop
    } else {
      EXPECT_LT(highest[i], 1.9) << speed[i] << " m/s, " << direction[i] << "°";  // all on their droop stops
    }
    const size_t j = at.at({speed[i], std::fmod(direction[i] + 90.0, 360.0)});
    EXPECT_NEAR(lowest[j], lowest[i], 1e-9) << speed[i] << " m/s, " << direction[i] << "°";
    EXPECT_NEAR(force[j], force[i], 1e-6 * force[i]) << speed[i] << " m/s, " << direction[i] << "°";
    unsafe += clearance[i] < 0.1505 ? 1 : 0;
  }
  EXPECT_GT(unsafe, 0);
  EXPECT_LT(unsafe, 24);
  EXPECT_TRUE(fs::exists(out / "operating_limits.png"));
  const std::string report = Slurp(out / "report.md");
  EXPECT_NE(
      report.find("Operating limits: " + std::to_string(unsafe) + " of 24 points unsafe (clearance below 0.1505 m)"),
      std::string::npos)
      << report;
}

TEST(Study, RunsGoToTheClusterOfAGivenScheduler) {
  // A cluster as it would run on other machines: dask-scheduler and a dask-worker started by
  // hand (here on this machine, the worker in a folder of its own with COSIM_BIN_DIR naming the
  // build), the study given --scheduler. The runs' scenario folder travels to the worker and
  // their outputs come back into the study folder (runs.csv, each run's history).
  const fs::path dir = TempDir("study_cluster");
  const fs::path file = dir / "scheduler.json", worker = dir / "worker";
  fs::create_directories(worker);
  ASSERT_EQ(std::system(("dask-scheduler --scheduler-file " + file.string() + " --port 0 --no-dashboard > " +
                         (dir / "scheduler.log").string() + " 2>&1 & echo $! > " + (dir / "scheduler.pid").string())
                            .c_str()),
            0);
  ASSERT_EQ(
      std::system(("cd " + worker.string() + " && COSIM_BIN_DIR=" + std::string(COSIM_BIN_DIR) +
                   " dask-worker --scheduler-file " + file.string() + " --nworkers 1 --nthreads 1 --no-dashboard > " +
                   (dir / "worker.log").string() + " 2>&1 & echo $! > " + (dir / "worker.pid").string())
                      .c_str()),
      0);
  std::string address;
  for (int k = 0; k < 200 && address.empty(); ++k) {  // the scheduler writes its address when it listens
    const std::string json = fs::exists(file) ? Slurp(file) : "";
    const auto at = json.find("\"address\": \"");
    if (at != std::string::npos) address = json.substr(at + 12, json.find('"', at + 12) - at - 12);
    if (address.empty()) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  const fs::path out = dir / "study";
  const int code = address.empty()
                       ? -1
                       : Study("envelope " + std::string(COSIM_SOURCE_DIR) + "/tests/data/envelope/pendulum.pbtxt" +
                                   " --scheduler " + address + " --out " + out.string(),
                               dir / "log.txt");
  for (const char* pid : {"worker.pid", "scheduler.pid"}) {  // stopped, and waited for (10 s, then killed)
    std::system(("p=$(cat " + (dir / pid).string() +
                 "); kill $p 2> /dev/null; for i in $(seq 50); do kill -0 $p 2> /dev/null || break; sleep 0.2; done; "
                 "kill -9 $p 2> /dev/null")
                    .c_str());
  }
  ASSERT_FALSE(address.empty()) << Slurp(dir / "scheduler.log");
  ASSERT_EQ(code, 0) << Slurp(dir / "log.txt") << Slurp(dir / "worker.log");
  EXPECT_NE(Slurp(dir / "log.txt").find("the Dask scheduler at " + address), std::string::npos)
      << Slurp(dir / "log.txt");
  EXPECT_EQ(ReadTable(out / "runs.csv").size(), 6u);
  EXPECT_TRUE(fs::exists(out / "runs" / "p0" / "history.csv"));
}

TEST(Study, CompareTakesARecordedHistoryASettledStartAndMeasures) {
  // tests/data/study/compare/hanging.pbtxt: a 1 kg body on a 100 N/m spring under gravity. The
  // closed-form equilibrium z = −m g/k comes as a recorded history (history_file); the run
  // started from its static equilibrium (settle_statically) stays on it; the run released at
  // the spring's length swings as z = −(m g/k)(1 − cos 10t). The measures against those
  // closed forms: the mean over [0, 0.3] s, −(m g/k)(1 − sin 3/3) released (the samples' mean
  // against the integral's: 1.3e-5); the lowest point −2 m g/k; the first return to the start
  // after 0.1 s, one period 2π/10 (to the 1 ms sampling and the 1e-4 m band). The report marks
  // the settled run's mean within the agreement asked and the released one's not.
  const fs::path out = TempDir("study_compare");
  ASSERT_EQ(Study("compare " + kData + "/compare/hanging.pbtxt --out " + out.string(), out / "log.txt"), 0)
      << Slurp(out / "log.txt");
  const Table m = ReadTable(out / "measures.csv");
  ASSERT_EQ(m.size(), 3u);
  const double g = 9.81 / 100;
  EXPECT_DOUBLE_EQ(m[0][1], -g);   // the recorded history, read back
  EXPECT_NEAR(m[0][2], -g, 1e-9);  // settled: it stays on the equilibrium
  EXPECT_NEAR(m[0][3], -g * (1 - std::sin(3.0) / 3), 5e-5);
  EXPECT_NEAR(m[1][2], -g, 1e-9);
  EXPECT_NEAR(m[1][3], -2 * g, 1e-4);
  EXPECT_NEAR(m[2][3], 2 * std::acos(-1.0) / 10, 0.005);
  const std::string report = Slurp(out / "report.md");
  EXPECT_NE(report.find("| settled |"), std::string::npos) << report;  // its wall time, not the recorded one's
  EXPECT_NE(report.find("| closed form | recorded: hanging_equilibrium.csv"), std::string::npos) << report;
  EXPECT_NE(report.find("✓) | "), std::string::npos) << report;
  EXPECT_NE(report.find("✗) | "), std::string::npos) << report;
  // Peaks keep their sign and a contact probe's unit is named (one column held N s per step, N
  // and N m unmarked, as magnitudes): the released run's lowest point, and its largest departure
  // from the closed form, both below it.
  const std::string contacts = Slurp(out / "contacts.csv");
  EXPECT_NE(contacts.find("peak_contact,contact_unit"), std::string::npos) << contacts;
  const Table c = ReadTable(out / "contacts.csv");
  ASSERT_EQ(c.size(), 1u) << contacts;
  EXPECT_NEAR(c[0][5], -2 * g, 1e-4);
  EXPECT_NE(contacts.find(",m,"), std::string::npos) << contacts;
  // The closed form's own peak is its value, −m g/k (it was printed as +m g/k); the released run
  // departs from it most at its start, +m g/k above it (and as far below at the bottom).
  const Table d = ReadTable(out / "differences.csv");
  ASSERT_EQ(d.size(), 2u);
  for (double p : d.Column("reference_peak")) EXPECT_NEAR(p, -g, 1e-9);
  const std::vector<double> peaks = d.Column("peak");
  EXPECT_NEAR(*std::max_element(peaks.begin(), peaks.end()), g, 1e-6);
  // --reuse keeps every run, the settled one too (its state was sent to the worker, whose copy
  // its summary records), and the measures are the same.
  const std::string first_measures = Slurp(out / "measures.csv");
  ASSERT_EQ(Study("compare " + kData + "/compare/hanging.pbtxt --reuse --out " + out.string(), out / "log2.txt"), 0)
      << Slurp(out / "log2.txt");
  const std::string again = Slurp(out / "log2.txt");
  EXPECT_NE(again.find("settled: kept from"), std::string::npos) << again;
  EXPECT_NE(again.find("released: kept from"), std::string::npos) << again;
  EXPECT_EQ(again.find(": ok;"), std::string::npos) << again;  // nothing ran again
  EXPECT_EQ(Slurp(out / "measures.csv"), first_measures);
  // Bad input names the place: a recorded history that is not there, a measure without a kind.
  EXPECT_EQ(Study("compare " + kData + "/compare/hanging.pbtxt --out " + (out / "bad1").string() +
                      " --set study.compare[0].history_file=\\\"nowhere.csv\\\"",
                  out / "bad1.txt"),
            2);
  EXPECT_NE(Slurp(out / "bad1.txt").find("study.compare[0].history_file: no such file"), std::string::npos)
      << Slurp(out / "bad1.txt");
  EXPECT_EQ(Study("compare " + kData + "/compare/hanging.pbtxt --out " + (out / "bad2").string() +
                      " --set study.measures[1].kind=KIND_UNSPECIFIED",
                  out / "bad2.txt"),
            2);
  EXPECT_NE(Slurp(out / "bad2.txt").find("study.measures[1].kind: missing"), std::string::npos)
      << Slurp(out / "bad2.txt");
}

TEST(Study, BadArgumentsAreRefused) {
  const fs::path out = TempDir("study_bad");
  EXPECT_EQ(Study("convergence " + kData + "/missing.pbtxt --out " + out.string(), out / "log.txt"), 2);
  EXPECT_NE(Study("sideways " + kData + "/oscillator.pbtxt", out / "log2.txt"), 0);
}

}  // namespace
