#pragma once
// What a smooth run's final_state.pb (proto/state.proto, SmoothState) holds besides q and q̇, so
// that a restart (numerics.initial_state) continues the run instead of starting it afresh: the
// run's SystemData (contact memories, rotor inflow, imposed coordinates) and CGα's history
// (accelerations, multipliers, a_n, the elastic midpoint force).
#include <google/protobuf/repeated_field.h>

#include <initializer_list>
#include <string>
#include <utility>

#include "smooth_solver/integrator/cgalpha.h"
#include "state.pb.h"

namespace cosim::smooth {

// The saved fields' values, for every part of the state that saves vectors (the data, CGα's
// history, a coupled run's coordinator): `v` appended to `out`; `in` into `v` if it holds `size`
// values (false if not); and the first field of `fields` (name, values) with a non-finite value,
// as "its PREFIXNAME[i] is not finite" (empty if none).
void AddValues(const Eigen::VectorXd& v, google::protobuf::RepeatedField<double>* out);
[[nodiscard]] bool ReadValues(const google::protobuf::RepeatedField<double>& in, int size, Eigen::VectorXd* v);
std::string NonFinite(
    std::initializer_list<std::pair<const char*, const google::protobuf::RepeatedField<double>*>> fields,
    const std::string& prefix = "");

void WriteData(const SystemData& data, state::SmoothState* saved);
// Whether `saved` holds a SystemData (written by a run since the data was saved).
bool HasSavedData(const state::SmoothState& saved);
// The saved SystemData into `data` (made by MakeData for this scene). Returns an empty string,
// or what does not match (the sizes of another scene's data): the caller's refusal.
[[nodiscard]] std::string ReadData(const state::SmoothState& saved, SystemData* data);

// What a CGα history belongs to: the run's last accepted step, its settings, whether it is adaptive.
struct HistoryOf {
  double step = 0.0;
  CgAlphaSettings settings;
  bool adaptive = false;
};
// CGα's history: the checkpoint's state (accelerations, multipliers), a_n, f̃_n and what they
// belong to.
void WriteCgAlphaHistory(const CgAlpha::Checkpoint& history, const HistoryOf& of, state::SmoothState* saved);
// Whether `saved` holds a CGα history that a run of `now` continues: started, of the same ρ∞,
// constraint form and GEMM choice, and of the same step unless both are adaptive.
bool HistoryFits(const state::SmoothState& saved, const HistoryOf& now);
// The saved history as a checkpoint at the state `at` (the saved q and q̇, read and checked by the
// caller) of an integrator of `constraints` rows (its data left alone). Returns an empty string,
// or what is wrong with it (sizes, non-finite values).
[[nodiscard]] std::string ReadCgAlphaHistory(const state::SmoothState& saved, const DaeState& at, int constraints,
                                             CgAlpha::Checkpoint* history);

}  // namespace cosim::smooth
