// A CGα run restarted from its final_state.pb (numerics.initial_state) goes on as the run made in
// one go: the saved state carries the step's accelerations and multipliers, CGα's history (a_n,
// the elastic midpoint force) and the run's data (the contact laws' onset speeds, the rotors'
// inflow), so the restart repeats the very steps the run would have taken.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "interface/base/errors.h"
#include "smooth_solver/simulation/multibody_simulation.h"
#include "state.pb.h"
#include "tests/interface/message_of.h"

namespace cosim::smooth {
namespace {

using Rows = std::vector<std::vector<double>>;

// Steps k = 0 … steps − 1 of `h` from `t0`; every probe after each.
Rows StepAndProbe(MultibodySimulation* sim, double t0, double h, int steps) {
  Rows rows;
  std::vector<double> values(sim->ProbeNames().size());
  for (int k = 0; k < steps; ++k) {
    sim->Step(t0 + k * h, h);
    sim->Probe(&values);
    rows.push_back(values);
  }
  return rows;
}

// The largest difference of each probe between `a` from row `offset` on and `b`, over the
// probe's largest magnitude in `b` (1 if it is 0).
std::vector<double> RelativeDifferences(const Rows& a, size_t offset, const Rows& b) {
  std::vector<double> worst(b.front().size(), 0.0), scale(b.front().size(), 0.0);
  for (size_t k = 0; k < b.size(); ++k) {
    for (size_t p = 0; p < b[k].size(); ++p) {
      worst[p] = std::max(worst[p], std::abs(a[offset + k][p] - b[k][p]));
      scale[p] = std::max(scale[p], std::abs(b[k][p]));
    }
  }
  for (size_t p = 0; p < worst.size(); ++p) worst[p] /= scale[p] > 0.0 ? scale[p] : 1.0;
  return worst;
}

// The saved state as a run saved it before the data and CGα's history were saved.
void WriteWithoutDataAndHistory(const std::string& from, const std::string& to) {
  state::SmoothState s;
  std::ifstream in(from, std::ios::binary);
  ASSERT_TRUE(s.ParseFromIstream(&in));
  for (int field : {10, 11, 12, 13, 14, 15, 16, 17, 18}) {
    s.GetReflection()->ClearField(&s, s.GetDescriptor()->FindFieldByNumber(field));
  }
  std::ofstream out(to, std::ios::binary);
  ASSERT_TRUE(s.SerializeToOstream(&out));
}

// The state `sim` saves in `folder` (final_state.pb), as read back.
state::SmoothState SaveState(MultibodySimulation* sim, const std::string& folder) {
  sim->BeginOutput(folder);
  sim->EndOutput();
  state::SmoothState saved;
  std::ifstream in(folder + "/final_state.pb", std::ios::binary);
  EXPECT_TRUE(saved.ParseFromIstream(&in)) << folder;
  return saved;
}

// Edits of a saved state, each with what the refusal of the edited state must say.
using Edits = std::vector<std::pair<std::function<void(state::SmoothState*)>, std::string>>;

// Each edit of `saved`, given to a run of the scene at `path` as numerics.initial_state, is
// refused with an InputError that names numerics.initial_state and says what the edit expects.
void ExpectEachEditRefused(const std::string& path, const state::SmoothState& saved, const Edits& edits,
                           const std::string& folder) {
  for (const auto& [edit, expected] : edits) {
    SCOPED_TRACE(expected);
    state::SmoothState s = saved;
    edit(&s);
    {
      std::ofstream out(folder + "/edited.pb", std::ios::binary);
      ASSERT_TRUE(s.SerializeToOstream(&out));
    }
    try {
      MultibodySimulation sim(interface::ScenarioFile::Load(
          path,
          {"numerics.start_time=" + std::to_string(s.time()), "numerics.initial_state=\"" + folder + "/edited.pb\""}));
      ADD_FAILURE() << "an edited state was accepted";
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("numerics.initial_state"), std::string::npos) << what;
      EXPECT_NE(what.find(expected), std::string::npos) << what;
    }
  }
}

struct Case {
  std::string scene;  // under scenarios/
  int first;          // steps before the restart (-1: up to the first step in contact)
  int after;          // steps after it
  std::string why;
};

TEST(Restart, ARestartedCgAlphaRunGoesOnAsTheRunMadeInOneGo) {
  // Two memories a restart used to lose, besides CGα's history. The hover rotor at 0.3 s: its
  // Pitt–Peters inflow is still building up (a state of its own, integrated step by step);
  // restarted, it was solved afresh as a momentum balance (observed: the probes 1e-3 off the run
  // made in one go). The pendulum pressed into its Hunt–Crossley stop: the law's onset speed δ̇⁻
  // is set while the contact approaches; restarted inside the contact it was 0, and the
  // dissipation term (∝ δ̇/δ̇⁻) threw the pendulum off (observed: the watchdog stops the run, the
  // energy up from −0.02 to 54 J in 10 steps). Saved and restored, each restarted run repeats the
  // run made in one go (observed: the rotor 1.6e-13 relative, the pendulum bit for bit). The
  // state a run saved before (without them) is still read, and restarts as it did.
  const std::vector<Case> cases{
      {"aero/hover_rotor.pbtxt", 300, 200, "Pitt–Peters inflow"},
      {"pendulum_stop_continuous.pbtxt", -1, 400, "onset speed inside a contact"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.scene);
    const std::string path = std::string(COSIM_SOURCE_DIR) + "/scenarios/" + c.scene;
    const double h = interface::ScenarioFile::Load(path, {}).proto().numerics().step();
    MultibodySimulation whole(interface::ScenarioFile::Load(path, {}));
    int first = c.first;
    Rows whole_rows;
    if (first < 0) {  // up to the first step whose end is in contact (tip_x < 0: into the stop)
      std::vector<double> values(whole.ProbeNames().size());
      for (int k = 0; first < 0 && k < 40000; ++k) {
        whole.Step(k * h, h);
        whole.Probe(&values);
        whole_rows.push_back(values);
        if (values[0] < 0.0) first = k + 1;
      }
      ASSERT_GT(first, 0) << "the pendulum never reached its stop";
    } else {
      whole_rows = StepAndProbe(&whole, 0.0, h, first);
    }
    const Rows rest = StepAndProbe(&whole, first * h, h, c.after);
    whole_rows.insert(whole_rows.end(), rest.begin(), rest.end());

    const std::string folder = ::testing::TempDir() + "restart_" + std::to_string(first);
    std::filesystem::create_directories(folder);
    MultibodySimulation part(interface::ScenarioFile::Load(path, {}));
    StepAndProbe(&part, 0.0, h, first);
    part.BeginOutput(folder);
    part.EndOutput();
    WriteWithoutDataAndHistory(folder + "/final_state.pb", folder + "/old_state.pb");
    auto restarted = [&](const std::string& state) {
      MultibodySimulation sim(interface::ScenarioFile::Load(
          path, {"numerics.start_time=" + std::to_string(first * h), "numerics.initial_state=\"" + state + "\""}));
      return StepAndProbe(&sim, first * h, h, c.after);
    };
    const std::vector<double> now =
        RelativeDifferences(whole_rows, static_cast<size_t>(first), restarted(folder + "/final_state.pb"));
    const double worst_now = *std::max_element(now.begin(), now.end());
    double worst_before = std::numeric_limits<double>::infinity();
    try {
      const std::vector<double> before =
          RelativeDifferences(whole_rows, static_cast<size_t>(first), restarted(folder + "/old_state.pb"));
      worst_before = *std::max_element(before.begin(), before.end());
    } catch (const NumericalError& e) {  // the old restart may not even run
      std::printf("restarted without the data and CGα's history: %s\n", e.what());
    }
    std::printf(
        "restart of %s at step %d (%s): largest relative difference from the run in one go %.1e "
        "(%.1e restarted without the data and CGα's history)\n",
        c.scene.c_str(), first, c.why.c_str(), worst_now, worst_before);
    EXPECT_LT(worst_now, 1e-10);
    EXPECT_GT(worst_before, 1e-4);  // what the restart lost (the old state is read all the same)
  }
}

TEST(Restart, ASavedStateWhoseDataOrHistoryIsNotTheScenesIsRefusedNamingTheField) {
  // A state of the same scene name and sizes but edited (or written by another version of the
  // scene): another number of contact memories, a history of another size, a non-finite onset
  // speed or a_n. Refused with exit 2 naming numerics.initial_state and what is wrong, not read
  // past its end nor carried into the run as NaN (which the watchdog would report as exit 3).
  const std::string path = std::string(COSIM_SOURCE_DIR) + "/scenarios/pendulum_stop_continuous.pbtxt";
  const std::string folder = ::testing::TempDir() + "restart_data_mismatch";
  std::filesystem::create_directories(folder);
  MultibodySimulation part(interface::ScenarioFile::Load(path, {}));
  StepAndProbe(&part, 0.0, 5e-5, 10);
  const state::SmoothState saved = SaveState(&part, folder);
  ASSERT_EQ(saved.impact_speed_size(), 1);
  ASSERT_GT(saved.acceleration_variable_size(), 0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const Edits edits{
      {[](state::SmoothState* s) { s->add_impact_speed(0.5); }, "2 contact memories"},
      {[](state::SmoothState* s) { s->mutable_lambda()->RemoveLast(); }, "is not of this scene's"},
      {[nan](state::SmoothState* s) { s->set_impact_speed(0, nan); }, "impact_speed[0] is not finite"},
      {[nan](state::SmoothState* s) { s->set_acceleration_variable(3, nan); },
       "acceleration_variable[3] is not finite"},
  };
  ExpectEachEditRefused(path, saved, edits, folder);
}

TEST(Restart, ASavedStateThatIsAFifoOrADeviceIsRefusedBeforeItIsRead) {
  // numerics.initial_state was read without the scenario reader's guards: a FIFO without a
  // writer hung the run for ever (in a coupled restart the contact process kept heart-beating,
  // so nothing gave up) and a link to /dev/zero was read into memory without end. Refused by what
  // it is, naming the field; a saved state whose reference_time is not finite is refused too.
  const std::string path = std::string(COSIM_SOURCE_DIR) + "/scenarios/pendulum_stop_continuous.pbtxt";
  const std::string folder = ::testing::TempDir() + "restart_not_a_file";
  std::filesystem::remove_all(folder);
  std::filesystem::create_directories(folder);
  ASSERT_EQ(::mkfifo((folder + "/fifo.pb").c_str(), 0600), 0);
  for (const auto& [file, why] :
       std::vector<std::pair<std::string, std::string>>{{folder + "/fifo.pb", "is a FIFO, not a regular file"},
                                                        {"/dev/zero", "is a character device, not a regular file"}}) {
    const std::string m = interface::MessageOf([&] {
      MultibodySimulation sim(interface::ScenarioFile::Load(path, {"numerics.initial_state=\"" + file + "\""}));
    });
    EXPECT_NE(m.find("numerics.initial_state: '" + file + "' " + why), std::string::npos) << m;
  }
  MultibodySimulation part(interface::ScenarioFile::Load(path, {}));
  StepAndProbe(&part, 0.0, 5e-5, 10);
  const state::SmoothState saved = SaveState(&part, folder);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  ExpectEachEditRefused(path, saved, {{[nan](state::SmoothState* s) { s->set_reference_time(nan); }, "reference_time"}},
                        folder);
  // A saved state's 50 MB scenario name gave a 52 MB message: quoted cut.
  state::SmoothState named = saved;
  named.set_scenario(std::string(50 << 20, 'x'));
  {
    std::ofstream out(folder + "/named.pb", std::ios::binary);
    ASSERT_TRUE(named.SerializeToOstream(&out));
  }
  const std::string m = interface::MessageOf([&] {
    MultibodySimulation sim(interface::ScenarioFile::Load(
        path,
        {"numerics.start_time=" + std::to_string(saved.time()), "numerics.initial_state=\"" + folder + "/named.pb\""}));
  });
  EXPECT_NE(m.find("is a state of scenario 'xxx"), std::string::npos) << m.substr(0, 500);
  EXPECT_LT(m.size(), 2000u);
  std::filesystem::remove_all(folder);
}

TEST(Restart, ASavedRotorInflowThatIsNotFiniteIsRefusedNamingTheRotorAndField) {
  // The rotors' saved frames and inflow were checked as a whole: a non-finite value was refused
  // as "its rotor 0 has a value that is not finite", leaving the user to search 14 numbers. Now
  // the message names the rotor and the field, for a vector and for a scalar alike.
  const std::string path = std::string(COSIM_SOURCE_DIR) + "/scenarios/aero/hover_rotor.pbtxt";
  const std::string folder = ::testing::TempDir() + "restart_rotor_not_finite";
  std::filesystem::create_directories(folder);
  MultibodySimulation part(interface::ScenarioFile::Load(path, {}));
  const double h = interface::ScenarioFile::Load(path, {}).proto().numerics().step();
  StepAndProbe(&part, 0.0, h, 5);
  const state::SmoothState saved = SaveState(&part, folder);
  ASSERT_EQ(saved.rotors_size(), 1);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const Edits edits{
      {[nan](state::SmoothState* s) { s->mutable_rotors(0)->set_nu(1, nan); }, "its rotors[0].nu[1] is not finite"},
      {[nan](state::SmoothState* s) { s->mutable_rotors(0)->set_v_normal(nan); },
       "its rotors[0].v_normal is not finite"},
  };
  ExpectEachEditRefused(path, saved, edits, folder);
}

TEST(Restart, AHistoryOfAnotherStepOrRhoInfOrNotStartedIsNotContinued) {
  // a_n approximates q̈ at t_n + (αm − αf) h: a run restarted with another step (a convergence
  // study's runs all start from one settling run's state, saved at the scene's step) or another
  // ρ∞ must start CGα afresh (consistent q̈ and λ, its start-up), as must a history whose start-up
  // was never taken. Each such restart is the one from the same state without its history, bit
  // for bit; the restart at the saved step and ρ∞ is not (it continues the history).
  const std::string pendulum = std::string(COSIM_SOURCE_DIR) + "/tests/data/rigid_pendulum.pbtxt";
  const std::string folder = ::testing::TempDir() + "restart_history_of";
  std::filesystem::create_directories(folder);
  const double h = 1e-3;
  const std::string spin = "model.bodies[arm].angular_velocity=[0, 9, 0]";  // swinging over the top
  MultibodySimulation part(interface::ScenarioFile::Load(pendulum, {spin}));
  StepAndProbe(&part, 0.0, h, 300);
  const state::SmoothState saved = SaveState(&part, folder);
  ASSERT_TRUE(saved.has_history_of());
  auto write = [&](const state::SmoothState& s, const std::string& name) {
    std::ofstream out(folder + "/" + name, std::ios::binary);
    ASSERT_TRUE(s.SerializeToOstream(&out));
  };
  state::SmoothState bare = saved, unstarted = saved;
  for (int field : {10, 11, 12, 13, 18})
    bare.GetReflection()->ClearField(&bare, bare.GetDescriptor()->FindFieldByNumber(field));
  unstarted.mutable_history_of()->set_started(false);
  write(bare, "bare.pb");
  write(unstarted, "unstarted.pb");
  auto run = [&](const std::string& state, double step, const std::string& rho_inf) {
    std::vector<std::string> sets{spin, "numerics.start_time=0.3", "numerics.step=" + std::to_string(step),
                                  "numerics.initial_state=\"" + folder + "/" + state + "\""};
    if (!rho_inf.empty()) sets.push_back("numerics.smooth.rho_inf=" + rho_inf);
    MultibodySimulation sim(interface::ScenarioFile::Load(pendulum, sets));
    std::vector<double> angles;  // (the scene has no probes)
    for (long k = 0; k < std::lround(0.2 / step); ++k) {
      sim.Step(0.3 + static_cast<double>(k) * step, step);
      angles.push_back(sim.system().JointCoordinate(0, sim.integrator().state().q));
    }
    return angles;
  };
  EXPECT_EQ(run("final_state.pb", h / 2, ""), run("bare.pb", h / 2, "")) << "another step";
  EXPECT_EQ(run("final_state.pb", h, "0.5"), run("bare.pb", h, "0.5")) << "another ρ∞";
  EXPECT_EQ(run("unstarted.pb", h, ""), run("bare.pb", h, "")) << "a history never started";
  EXPECT_NE(run("final_state.pb", h, ""), run("bare.pb", h, "")) << "the history was not continued";
}

}  // namespace
}  // namespace cosim::smooth
