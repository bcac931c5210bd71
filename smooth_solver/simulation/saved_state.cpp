#include "smooth_solver/simulation/saved_state.h"

#include <google/protobuf/repeated_field.h>

#include <cmath>
#include <initializer_list>
#include <utility>

namespace cosim::smooth {

namespace {

using Doubles = google::protobuf::RepeatedField<double>;

void Add(const Eigen::Vector3d& v, Doubles* out) { out->Add(v.data(), v.data() + 3); }
void Add(const Eigen::VectorXd& v, Doubles* out) { AddValues(v, out); }

// The three values of `in` (false if it has not three).
bool Read(const Doubles& in, Eigen::Vector3d* v) {
  if (in.size() != 3) return false;
  *v = Eigen::Vector3d(in.Get(0), in.Get(1), in.Get(2));
  return true;
}

bool Read(const Doubles& in, int size, Eigen::VectorXd* v) { return ReadValues(in, size, v); }

}  // namespace

void AddValues(const Eigen::VectorXd& v, Doubles* out) { out->Add(v.data(), v.data() + v.size()); }

bool ReadValues(const Doubles& in, int size, Eigen::VectorXd* v) {
  if (in.size() != size) return false;
  *v = Eigen::Map<const Eigen::VectorXd>(in.data(), size);
  return true;
}

std::string NonFinite(std::initializer_list<std::pair<const char*, const Doubles*>> fields, const std::string& prefix) {
  for (const auto& [name, values] : fields) {
    for (int i = 0; i < values->size(); ++i) {
      if (!std::isfinite(values->Get(i))) return "its " + prefix + name + "[" + std::to_string(i) + "] is not finite";
    }
  }
  return {};
}

void WriteData(const SystemData& data, state::SmoothState* saved) {
  saved->mutable_impact_speed()->Add(data.impact_speed.begin(), data.impact_speed.end());
  for (const RotorInflowState& r : data.rotors) {
    state::SmoothState::Rotor* out = saved->add_rotors();
    Add(r.centre, out->mutable_centre());
    Add(r.n, out->mutable_n());
    Add(r.x, out->mutable_x());
    Add(r.y, out->mutable_y());
    Add(r.downstream, out->mutable_downstream());
    Add(r.nu, out->mutable_nu());
    out->set_v_normal(r.v_normal);
    out->set_v_parallel(r.v_parallel);
    out->set_tip_speed(r.tip_speed);
    out->set_fade(r.fade);
    out->set_t(r.t);
    out->set_started(r.started);
  }
  for (const ImposedCoordinate& x : data.imposed) {
    state::SmoothState::Imposed* out = saved->add_imposed();
    out->set_value(x.value);
    out->set_rate(x.rate);
    out->set_acceleration(x.acceleration);
  }
  // (Not the peers' interface compliance: the coordinator sets it from their answers.)
}

bool HasSavedData(const state::SmoothState& saved) {
  // (A scene without memories, rotors or interface points saves nothing: its data is MakeData's.)
  return saved.impact_speed_size() > 0 || saved.rotors_size() > 0 || saved.imposed_size() > 0;
}

std::string ReadData(const state::SmoothState& saved, SystemData* data) {
  if (saved.impact_speed_size() != static_cast<int>(data->impact_speed.size()) ||
      saved.rotors_size() != static_cast<int>(data->rotors.size()) ||
      saved.imposed_size() != static_cast<int>(data->imposed.size())) {
    return "its data (" + std::to_string(saved.impact_speed_size()) + " contact memories, " +
           std::to_string(saved.rotors_size()) + " rotors, " + std::to_string(saved.imposed_size() / 3) +
           " interface points) is not this scene's (" + std::to_string(data->impact_speed.size()) + ", " +
           std::to_string(data->rotors.size()) + ", " + std::to_string(data->imposed.size() / 3) + ")";
  }
  if (std::string bad = NonFinite({{"impact_speed", &saved.impact_speed()}}); !bad.empty()) return bad;
  SystemData restored = *data;
  for (int i = 0; i < saved.impact_speed_size(); ++i) {
    restored.impact_speed[static_cast<size_t>(i)] = saved.impact_speed(i);
  }
  for (int k = 0; k < saved.rotors_size(); ++k) {
    const state::SmoothState::Rotor& in = saved.rotors(k);
    RotorInflowState& r = restored.rotors[static_cast<size_t>(k)];
    if (!Read(in.centre(), &r.centre) || !Read(in.n(), &r.n) || !Read(in.x(), &r.x) || !Read(in.y(), &r.y) ||
        !Read(in.downstream(), &r.downstream) || !Read(in.nu(), &r.nu)) {
      return "its rotor " + std::to_string(k) + " lacks a vector of three values";
    }
    const std::string rotor = "rotors[" + std::to_string(k) + "].";
    std::string bad = NonFinite({{"centre", &in.centre()},
                                 {"n", &in.n()},
                                 {"x", &in.x()},
                                 {"y", &in.y()},
                                 {"downstream", &in.downstream()},
                                 {"nu", &in.nu()}},
                                rotor);
    const std::pair<const char*, double> scalars[] = {{"v_normal", in.v_normal()},
                                                      {"v_parallel", in.v_parallel()},
                                                      {"tip_speed", in.tip_speed()},
                                                      {"fade", in.fade()},
                                                      {"t", in.t()}};
    for (const auto& [name, value] : scalars) {
      if (bad.empty() && !std::isfinite(value)) bad = "its " + rotor + name + " is not finite";
    }
    if (!bad.empty()) return bad;
    r.v_normal = in.v_normal();
    r.v_parallel = in.v_parallel();
    r.tip_speed = in.tip_speed();
    r.fade = in.fade();
    r.t = in.t();
    r.started = in.started();
  }
  for (int i = 0; i < saved.imposed_size(); ++i) {
    const state::SmoothState::Imposed& in = saved.imposed(i);
    if (!std::isfinite(in.value()) || !std::isfinite(in.rate()) || !std::isfinite(in.acceleration())) {
      return "its imposed[" + std::to_string(i) + "] is not finite";
    }
    ImposedCoordinate& x = restored.imposed[static_cast<size_t>(i)];
    x.value = in.value();
    x.rate = in.rate();
    x.acceleration = in.acceleration();
  }
  // (The interface compliance stays zero, MakeData's: the coordinator sets it from the peers' answers.)
  data->CopyFrom(restored);
  return {};
}

void WriteCgAlphaHistory(const CgAlpha::Checkpoint& history, const HistoryOf& of, state::SmoothState* saved) {
  Add(history.state.qddot, saved->mutable_qddot());
  Add(history.state.lambda, saved->mutable_lambda());
  Add(history.a, saved->mutable_acceleration_variable());
  Add(history.elastic, saved->mutable_elastic_force());
  state::SmoothState::HistoryOf* out = saved->mutable_history_of();
  out->set_step(of.step);
  out->set_rho_inf(of.settings.rho_inf);
  out->set_form(static_cast<int>(of.settings.form));
  out->set_gemm(of.settings.gemm);
  out->set_started(history.started);
  out->set_adaptive(of.adaptive);
}

bool HistoryFits(const state::SmoothState& saved, const HistoryOf& now) {
  if (!saved.has_history_of() || saved.acceleration_variable_size() == 0) return false;
  const state::SmoothState::HistoryOf& of = saved.history_of();
  const bool same_step =
      now.adaptive ? of.adaptive() : !of.adaptive() && std::abs(of.step() - now.step) <= 1e-12 * now.step;
  return of.started() && same_step && of.rho_inf() == now.settings.rho_inf &&
         of.form() == static_cast<int>(now.settings.form) && of.gemm() == now.settings.gemm;
}

std::string ReadCgAlphaHistory(const state::SmoothState& saved, const DaeState& at, int constraints,
                               CgAlpha::Checkpoint* history) {
  const int coordinates = static_cast<int>(at.q.size());
  history->state = at;  // (q and q̇ as the caller read and checked them)
  history->started = true;
  if (!Read(saved.qddot(), coordinates, &history->state.qddot) ||
      !Read(saved.lambda(), constraints, &history->state.lambda) ||
      !Read(saved.acceleration_variable(), coordinates, &history->a) ||
      !Read(saved.elastic_force(), coordinates, &history->elastic)) {
    return "its CGα history (qddot, lambda, acceleration_variable, elastic_force: " +
           std::to_string(saved.qddot_size()) + ", " + std::to_string(saved.lambda_size()) + ", " +
           std::to_string(saved.acceleration_variable_size()) + ", " + std::to_string(saved.elastic_force_size()) +
           " values) is not of this scene's " + std::to_string(coordinates) + " coordinates and " +
           std::to_string(constraints) + " constraints";
  }
  return NonFinite({{"qddot", &saved.qddot()},
                    {"lambda", &saved.lambda()},
                    {"acceleration_variable", &saved.acceleration_variable()},
                    {"elastic_force", &saved.elastic_force()}});
}

}  // namespace cosim::smooth
