#pragma once
// What a smooth run's final_state.pb (proto/state.proto, SmoothState) holds besides q and q̇, so
// that a restart (numerics.initial_state) continues the run instead of starting it afresh: the
// run's SystemData (contact memories, rotor inflow, imposed coordinates) and CGα's history
// (accelerations, multipliers, a_n, the elastic midpoint force).
#include <string>

#include "smooth_solver/integrator/cgalpha.h"
#include "state.pb.h"

namespace cosim::smooth {

void SaveData(const SystemData& data, state::SmoothState* saved);
// Whether `saved` holds a SystemData (written by a run since the data was saved).
bool HasSavedData(const state::SmoothState& saved);
// The saved SystemData into `data` (made by MakeData for this scene). Returns an empty string,
// or what does not match (the sizes of another scene's data): the caller's refusal.
std::string RestoreData(const state::SmoothState& saved, SystemData* data);

// What a CGα history belongs to: the run's last accepted step, its settings, whether it is adaptive.
struct HistoryOf {
  double step = 0.0;
  CgAlphaSettings settings;
  bool adaptive = false;
};
// CGα's history: the checkpoint's state (accelerations, multipliers), a_n, f̃_n and what they
// belong to.
void SaveHistory(const CgAlpha::Checkpoint& history, const HistoryOf& of, state::SmoothState* saved);
// Whether `saved` holds a CGα history that a run of `now` continues: started, of the same ρ∞,
// constraint form and GEMM choice, and of the same step unless both are adaptive.
bool HistoryFits(const state::SmoothState& saved, const HistoryOf& now);
// The saved history as a checkpoint at the state `at` (the saved q and q̇, read and checked by the
// caller) of an integrator of `constraints` rows (its data left alone). Returns an empty string,
// or what is wrong with it (sizes, non-finite values).
std::string RestoreHistory(const state::SmoothState& saved, const DaeState& at, int constraints,
                           CgAlpha::Checkpoint* history);

}  // namespace cosim::smooth
