#include "smooth_solver/model/aero_input.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>

#include "interface/base/input_file.h"
#include "smooth_solver/elastic/elastic_model.h"
#include "smooth_solver/model/multibody_model.h"

namespace cosim::smooth {

namespace sc = cosim::scenario;
using interface::Checks;
using interface::ElementPath;
using interface::FormatNumber;

namespace {

// An airwake survey's grid: every (x, y) of its distinct x's and y's exactly once, any order.
void ReadAirwakeGrid(const Checks& checks, const std::string& path, const sc::Airwake& a, Airwake* w) {
  if (a.grid_size() == 0) checks.Fail(path + ".grid", "is empty; give grid_file or the grid's points");
  for (const sc::Airwake::GridPoint& p : a.grid()) {
    w->xs.push_back(p.x());
    w->ys.push_back(p.y());
  }
  for (std::vector<double>* knots : {&w->xs, &w->ys}) {
    std::sort(knots->begin(), knots->end());
    knots->erase(std::unique(knots->begin(), knots->end()), knots->end());
  }
  const size_t nx = w->xs.size(), ny = w->ys.size();
  if (static_cast<size_t>(a.grid_size()) != nx * ny) {
    checks.Fail(path + ".grid", std::to_string(a.grid_size()) + " points over " + std::to_string(nx) +
                                    " distinct x and " + std::to_string(ny) +
                                    " distinct y; a rectangular grid has every (x, y) once (" +
                                    std::to_string(nx * ny) + " points)");
  }
  w->grid.assign(nx * ny, Eigen::Vector3d::Zero());
  std::vector<bool> seen(nx * ny, false);
  for (int k = 0; k < a.grid_size(); ++k) {
    const sc::Airwake::GridPoint& p = a.grid(k);
    const size_t i = static_cast<size_t>(std::lower_bound(w->xs.begin(), w->xs.end(), p.x()) - w->xs.begin());
    const size_t j = static_cast<size_t>(std::lower_bound(w->ys.begin(), w->ys.end(), p.y()) - w->ys.begin());
    if (seen[i * ny + j]) {
      checks.Fail(ElementPath(path + ".grid", k),
                  "repeats the point (" + FormatNumber(p.x()) + ", " + FormatNumber(p.y()) + "); each once");
    }
    seen[i * ny + j] = true;
    w->grid[i * ny + j] = Eigen::Vector3d(p.u(), p.v(), p.w());
  }
}

// proto Airwake, validated: every form's own fields present, none of another form's.
Airwake BuildAirwake(const Checks& checks, const sc::Airwake& a) {
  const std::string path = "model.air.airwake";
  Airwake w;
  checks.Require(path + ".speed", a.has_speed(), "the mean wind speed V [m/s] >= 0");
  w.speed = checks.NonNegative(path + ".speed", a.speed(), "m/s");
  checks.Require(path + ".form", a.form() != sc::Airwake::FORM_UNSPECIFIED, "UNIFORM, LINEAR, STEP or TABLE");
  w.origin = checks.Vector3(path + ".origin", a.origin(), Eigen::Vector3d::Zero());
  w.up = a.up_size() > 0 ? checks.Direction(path + ".up", a.up()) : Eigen::Vector3d::UnitZ();
  w.bow = a.bow_size() > 0 ? checks.Direction(path + ".bow", a.bow()) : Eigen::Vector3d::UnitX();
  if (std::abs(w.bow.dot(w.up)) > 1e-9) {
    checks.Fail(path + ".bow", "must be perpendicular to up (the ship's forward axis is horizontal); bow · up = " +
                                   FormatNumber(w.bow.dot(w.up)));
  }
  w.port = w.up.cross(w.bow);
  if (checks.NonNegative(path + ".ramp_time", a.ramp_time(), "s") > 0.0) {
    // ½ (1 − cos(π t / T)) from t = 0: Eq. (37)'s cosine ramp to 1 (zero before it).
    sc::TimeFunction ramp;
    ramp.mutable_cosine_ramp()->set_final_value(1.0);
    ramp.mutable_cosine_ramp()->set_ramp_time(a.ramp_time());
    w.growth = interface::TimeFunction::Build(checks, path + ".ramp_time", ramp);
  }
  const sc::Airwake::Form form = a.form();
  // Which fields each form reads; any other given is refused, not ignored.
  const bool uses_leeward = form == sc::Airwake::LINEAR || form == sc::Airwake::STEP;
  const std::vector<std::pair<std::string, bool>> unused = {
      {"direction", form == sc::Airwake::TABLE && a.has_direction()},
      {"windward", form == sc::Airwake::TABLE && a.has_windward()},
      {"leeward", !uses_leeward && a.has_leeward()},
      {"length", form != sc::Airwake::LINEAR && a.has_length()},
      {"edge", form != sc::Airwake::STEP && a.has_edge()},
      {"edge_width", form != sc::Airwake::STEP && a.has_edge_width()},
      {"grid", form != sc::Airwake::TABLE && a.grid_size() > 0}};
  for (const auto& [field, given] : unused) {
    if (given) checks.Fail(path + "." + field, "is not read by form " + sc::Airwake::Form_Name(form) + "; remove it");
  }
  if (form == sc::Airwake::TABLE) {
    w.form = Airwake::Form::kTable;
    ReadAirwakeGrid(checks, path, a, &w);
    return w;
  }
  checks.Require(path + ".direction", a.has_direction(),
                 "the relative wind direction [deg]: where the wind comes from, clockwise from the bow (0: head wind)");
  const double psi = a.direction() * std::numbers::pi / 180.0;
  w.along = -std::cos(psi) * w.bow + std::sin(psi) * w.port;  // V (−cos ψ, sin ψ) in ship axes
  checks.Require(path + ".windward", a.has_windward(), "the vertical velocity over V on the windward side");
  w.windward = a.windward();
  if (uses_leeward) {
    checks.Require(path + ".leeward", a.has_leeward(), "the vertical velocity over V on the leeward side");
    w.leeward = a.leeward();
  }
  switch (form) {
    case sc::Airwake::UNIFORM:
      w.form = Airwake::Form::kUniform;
      break;
    case sc::Airwake::LINEAR:
      w.form = Airwake::Form::kLinear;
      w.length = checks.Positive(path + ".length", a.has_length(), a.length(), "m");
      break;
    case sc::Airwake::STEP:
      w.form = Airwake::Form::kStep;
      w.edge = a.edge();
      w.edge_width = checks.Positive(path + ".edge_width", a.has_edge_width(), a.edge_width(), "m");
      break;
    default:
      checks.Fail(path + ".form", "unknown form " + std::to_string(static_cast<int>(form)));
  }
  return w;
}

}  // namespace

namespace {

// model.air's field: density, speed of sound, wind, airwake and gust fronts.
void ReadAir(const Checks& checks, const sc::Air& a, AirModel* air_out) {
  AirModel& air = *air_out;
  air.density = checks.Positive("model.air.density", true, a.density(), "kg/m^3");
  air.speed_of_sound = checks.Positive("model.air.speed_of_sound", true, a.speed_of_sound(), "m/s");
  air.guard_speed = checks.Positive("model.air.guard_speed", true, a.guard_speed(), "m/s");
  if (a.has_wind_x()) air.wind[0] = interface::TimeFunction::Build(checks, "model.air.wind_x", a.wind_x());
  if (a.has_wind_y()) air.wind[1] = interface::TimeFunction::Build(checks, "model.air.wind_y", a.wind_y());
  if (a.has_wind_z()) air.wind[2] = interface::TimeFunction::Build(checks, "model.air.wind_z", a.wind_z());
  if (a.has_airwake()) air.airwake = BuildAirwake(checks, a.airwake());
  for (int i = 0; i < a.gusts_size(); ++i) {
    const sc::Gust& g = a.gusts(i);
    const std::string path = ElementPath("model.air.gusts", i);
    GustFront front;
    front.front_direction = checks.Direction(path + ".front_direction", g.front_direction());
    front.direction = checks.Direction(path + ".direction", g.direction());
    front.front_speed = checks.Positive(path + ".front_speed", g.has_front_speed(), g.front_speed(), "m/s");
    front.origin = checks.Vector3(path + ".front_origin", g.front_origin(), Eigen::Vector3d::Zero());
    checks.Require(path + ".profile", g.has_profile(), "the gust speed [m/s] against the distance travelled [m]");
    front.profile = interface::TimeFunction::Build(checks, path + ".profile", g.profile());
    air.gusts.push_back(std::move(front));
  }
}

// The airfoils: the built-in NACA 0012 first, then the scenario's (C81 tables, or the built-in
// one with another lift slope).
void AddAirfoils(const Checks& checks, const sc::Air& a, interface::NameTable* airfoil_names, AeroModel* aero_out) {
  AeroModel& aero = *aero_out;
  airfoil_names->Add("(built in)", "naca0012");
  aero.airfoils.push_back(std::make_shared<BuiltinNaca0012>());
  aero.airfoil_names.push_back("naca0012");
  const std::filesystem::path folder = std::filesystem::path(checks.file().path()).parent_path();
  for (int i = 0; i < a.airfoils_size(); ++i) {
    const sc::Airfoil& f = a.airfoils(i);
    const std::string path = ElementPath("model.air.airfoils", i);
    const std::string name = airfoil_names->Declare(path + ".name", f.has_name(), f.name());
    if (f.has_builtin_lift_slope()) {
      if (f.has_c81_file()) checks.Fail(path, "gives both c81_file and builtin_lift_slope; give one");
      const double slope = checks.Positive(path + ".builtin_lift_slope", true, f.builtin_lift_slope(), "1/rad");
      aero.airfoils.push_back(std::make_shared<BuiltinNaca0012>(name, slope));
      aero.airfoil_names.push_back(name);
      continue;
    }
    checks.Require(path + ".c81_file", f.has_c81_file(),
                   "a C81 table file (path relative to the scenario) or builtin_lift_slope");
    std::filesystem::path file(f.c81_file());
    if (file.is_relative()) file = folder / file;
    const interface::InputFile text = interface::ReadInputFile(file, interface::kMaxAirfoilBytes);
    if (!text.ok()) checks.Fail(path + ".c81_file", text.why + "; expected a C81 airfoil table");
    aero.airfoils.push_back(C81Airfoil::Parse(text.text, file.string(), name));
    aero.airfoil_names.push_back(name);
  }
}

// A surface's carrier, with the span its stations may take [s_lo, s_hi] and the untwisted
// section's flapwise axis in the initial configuration.
void ReadBeamCarrier(const Checks& checks, const sc::AeroSurface& s, const std::string& path,
                     const interface::NameTable& beam_names, const MultibodyModel& model, AeroSurfaceSpec* sf,
                     Eigen::Vector3d* normal_ref, double* s_lo, double* s_hi) {
  const int b = beam_names.Find(path + ".beam", s.beam());
  sf->on_beam = true;
  sf->beam = model.beams[static_cast<size_t>(b)];
  *normal_ref = sf->beam.d3_0;
  *s_lo = sf->beam.span_start;
  *s_hi = sf->beam.span_end;
  for (const char* f : {"root", "axis", "chord"}) {  // the beam's own
    const bool given = f[0] == 'r' ? s.root_size() > 0 : f[0] == 'a' ? s.axis_size() > 0 : s.chord_size() > 0;
    if (given) checks.Fail(path + "." + f, "is the beam's own on a beam surface; remove it");
  }
  if (s.has_segments())
    checks.Fail(path + ".segments", "a beam surface integrates over the beam's elements; remove it");
}

void ReadBodyCarrier(const Checks& checks, const sc::AeroSurface& s, const std::string& path,
                     const interface::NameTable& body_names, const MultibodyModel& model, AeroSurfaceSpec* sf,
                     Eigen::Vector3d* normal_ref, double* s_lo, double* s_hi) {
  const int b = body_names.Find(path + ".body", s.body());
  if (b < 0 || static_cast<size_t>(b) >= model.bodies.size()) checks.Fail(path + ".body", "is not a rigid body");
  const RigidBody& body = model.bodies[static_cast<size_t>(b)];
  for (const BeamModel& beam : model.beams) {
    for (int node : beam.node_bodies) {
      if (node == b)
        checks.Fail(path + ".body", "'" + s.body() + "' is a beam node; use `beam: \"" + beam.name + "\"`");
    }
  }
  sf->body = b;
  const Eigen::Matrix3d R = body.orientation.toRotationMatrix();
  const Eigen::Vector3d root = checks.Vector3(path + ".root", s.root(), std::nullopt);
  const Eigen::Vector3d axis = checks.Direction(path + ".axis", s.axis());
  const Eigen::Vector3d chord = checks.AcrossAxis(path + ".chord", s.chord(), axis);
  sf->root_b = R.transpose() * (root - body.position);
  sf->axis_b = R.transpose() * axis;
  sf->chord_b = R.transpose() * chord;
  *normal_ref = axis.cross(chord);
  sf->segments = static_cast<int>(checks.InRange(path + ".segments", true, s.segments(), 1, 10000));
  *s_lo = -1e300;
  *s_hi = 1e300;
}

void ReadElasticCarrier(const Checks& checks, const sc::AeroSurface& s, const std::string& path,
                        const MultibodyModel& model, std::vector<ElasticMesh>* elastic_meshes, AeroSurfaceSpec* sf,
                        Eigen::Vector3d* normal_ref, double* s_lo, double* s_hi) {
  const sc::Model& m = checks.file().proto().model();
  int e = -1;
  for (int k = 0; k < m.elastic_bodies_size(); ++k) {
    if (m.elastic_bodies(k).name() == s.elastic_body()) e = k;
  }
  if (e < 0) {
    std::string known;
    for (const auto& eb : m.elastic_bodies()) known += (known.empty() ? "" : ", ") + eb.name();
    checks.Fail(path + ".elastic_body",
                "no elastic body named '" + s.elastic_body() + "'" + (known.empty() ? "" : "; known: " + known));
  }
  if (elastic_meshes->empty()) {
    for (const ElasticBodySpec& spec : BuildElasticBodies(checks, m, model.BodyNames())) {
      elastic_meshes->push_back(spec.body.mesh());
    }
  }
  sf->elastic = e;
  sf->mesh = (*elastic_meshes)[static_cast<size_t>(e)];
  const Eigen::Vector3d axis = checks.Direction(path + ".axis", s.axis());
  sf->root_b = checks.Vector3(path + ".root", s.root(), std::nullopt);
  sf->axis_b = axis;
  sf->chord_b = checks.AcrossAxis(path + ".chord", s.chord(), axis);
  *normal_ref = axis.cross(sf->chord_b);
  sf->segments = static_cast<int>(checks.InRange(path + ".segments", true, s.segments(), 1, 10000));
  *s_lo = 0.0;
  *s_hi = 1e300;
}

// The surface's stations within [s_lo, s_hi], and (on an elastic body) inside its mesh.
void ReadStations(const Checks& checks, const sc::AeroSurface& s, const std::string& path,
                  const interface::NameTable& airfoil_names, double s_lo, double s_hi, AeroSurfaceSpec* sf) {
  if (s.stations_size() < 2)
    checks.Fail(path + ".stations", "needs at least two stations (root and tip of the loaded span)");
  for (int k = 0; k < s.stations_size(); ++k) {
    const sc::AeroStation& st = s.stations(k);
    const std::string sp = ElementPath(path + ".stations", k);
    AeroStationSpec spec;
    checks.Require(sp + ".s", st.has_s(), "the span coordinate [m]");
    spec.s = st.s();
    if (k > 0 && spec.s < sf->stations.back().s) {
      checks.Fail(sp + ".s", FormatNumber(spec.s) + " is below the previous station's " +
                                 FormatNumber(sf->stations.back().s) + "; stations must not decrease");
    }
    if (spec.s < s_lo - 1e-9 || spec.s > s_hi + 1e-9) {
      checks.Fail(sp + ".s", FormatNumber(spec.s) + " lies outside the beam's span " + FormatNumber(s_lo) + " … " +
                                 FormatNumber(s_hi));
    }
    if (!sf->on_beam && spec.s < 0.0) checks.Fail(sp + ".s", "is negative; s is the distance from `root`");
    spec.chord = checks.Positive(sp + ".chord", st.has_chord(), st.chord(), "m");
    spec.twist = st.twist();
    spec.quarter_chord = st.quarter_chord();
    checks.Require(sp + ".airfoil", st.has_airfoil(), "an airfoil name (\"naca0012\" is built in)");
    spec.airfoil = airfoil_names.Find(sp + ".airfoil", st.airfoil());
    sf->stations.push_back(spec);
  }
  if (!(sf->stations.back().s > sf->stations.front().s)) {
    checks.Fail(path + ".stations", "span no length; the last station's s must exceed the first's");
  }
  if (sf->elastic >= 0) {  // the loaded span inside the mesh (ends and a few points between)
    MeshPoint at;
    for (int k = 0; k <= 20; ++k) {
      const double sk = sf->stations.front().s + (sf->stations.back().s - sf->stations.front().s) * k / 20.0;
      if (!LocateInMesh(sf->mesh, sf->root_b + sk * sf->axis_b, &at)) {
        checks.Fail(path + ".stations", "the reference line at s = " + FormatNumber(sk) +
                                            " m lies outside elastic body '" + s.elastic_body() +
                                            "'; stations must stay inside its mesh");
      }
    }
  }
}

AeroSurfaceSpec ReadSurface(const Checks& checks, const sc::AeroSurface& s, const std::string& path,
                            const interface::NameTable& body_names, const interface::NameTable& beam_names,
                            const interface::NameTable& airfoil_names, const MultibodyModel& model,
                            interface::NameTable* surface_names, std::vector<ElasticMesh>* elastic_meshes) {
  AeroSurfaceSpec sf;
  sf.name = surface_names->Declare(path + ".name", s.has_name(), s.name());
  const Eigen::Vector3d upper = checks.Direction(path + ".upper", s.upper());
  sf.gauss_points = static_cast<int>(checks.InRange(path + ".gauss_points", true, s.gauss_points(), 1, 6));
  Eigen::Vector3d normal_ref = Eigen::Vector3d::Zero();  // the untwisted section's flapwise axis, initial configuration
  double s_lo = 0.0, s_hi = 0.0;
  switch (s.carrier_case()) {
    case sc::AeroSurface::kBeam:
      ReadBeamCarrier(checks, s, path, beam_names, model, &sf, &normal_ref, &s_lo, &s_hi);
      break;
    case sc::AeroSurface::kBody:
      ReadBodyCarrier(checks, s, path, body_names, model, &sf, &normal_ref, &s_lo, &s_hi);
      break;
    case sc::AeroSurface::kElasticBody:
      ReadElasticCarrier(checks, s, path, model, elastic_meshes, &sf, &normal_ref, &s_lo, &s_hi);
      break;
    case sc::AeroSurface::CARRIER_NOT_SET:
      checks.Fail(path, "names no carrier; give `beam: NAME`, `body: NAME` or `elastic_body: NAME`");
  }
  const double side = upper.dot(normal_ref);
  if (std::abs(side) < 1e-3) {
    checks.Fail(path + ".upper", "lies in the chord plane; it must point to the side of the upper surface");
  }
  sf.upper_sign = side > 0.0 ? 1.0 : -1.0;
  ReadStations(checks, s, path, airfoil_names, s_lo, s_hi, &sf);
  return sf;
}

// A rotor: its hub, radius and inflow model, and the surfaces that are its blades.
RotorSpec ReadRotor(const Checks& checks, const sc::Air& a, int i, const interface::NameTable& body_names,
                    const interface::NameTable& surface_names, const MultibodyModel& model,
                    interface::NameTable* rotor_names, AeroModel* aero_out) {
  AeroModel& aero = *aero_out;
  const sc::Rotor& r = a.rotors(i);
  const std::string path = ElementPath("model.air.rotors", i);
  RotorSpec rs;
  rs.name = rotor_names->Declare(path + ".name", r.has_name(), r.name());
  checks.Require(path + ".hub", r.has_hub(), "the body carrying the blades");
  rs.hub = body_names.Find(path + ".hub", r.hub());
  if (rs.hub < 0) checks.Fail(path + ".hub", "the ground cannot be a hub; name the body that turns");
  const Eigen::Matrix3d R = model.bodies[static_cast<size_t>(rs.hub)].orientation.toRotationMatrix();
  rs.axis_b = R.transpose() * checks.Direction(path + ".axis", r.axis());
  rs.radius = checks.Positive(path + ".radius", r.has_radius(), r.radius(), "m");
  rs.guard_tip_speed = checks.Positive(path + ".guard_tip_speed", true, r.guard_tip_speed(), "m/s");
  rs.induced_velocity_factor =
      checks.InRange(path + ".induced_velocity_factor", true, r.induced_velocity_factor(), 1.0, 2.0);
  switch (r.inflow()) {
    case sc::Rotor::NONE:
      rs.inflow = RotorSpec::Inflow::kNone;
      break;
    case sc::Rotor::UNIFORM:
      rs.inflow = RotorSpec::Inflow::kUniform;
      break;
    case sc::Rotor::PITT_PETERS:
      rs.inflow = RotorSpec::Inflow::kPittPeters;
      break;
    default:
      checks.Fail(path + ".inflow", "give NONE, UNIFORM or PITT_PETERS");
  }
  if (r.has_induced_velocity_factor() && rs.inflow != RotorSpec::Inflow::kUniform) {
    checks.Fail(path + ".induced_velocity_factor",
                "applies to UNIFORM inflow only; this rotor's inflow is " + sc::Rotor::Inflow_Name(r.inflow()));
  }
  if (r.surfaces_size() == 0) checks.Fail(path + ".surfaces", "lists no aero surface; name the rotor's blades");
  for (int k = 0; k < r.surfaces_size(); ++k) {
    const std::string sp = path + ".surfaces[" + std::to_string(k) + "]";
    const int s = surface_names.Find(sp, r.surfaces(k));
    AeroSurfaceSpec& sf = aero.surfaces[static_cast<size_t>(s)];
    if (sf.rotor >= 0) {
      checks.Fail(sp, "'" + r.surfaces(k) + "' already belongs to rotor '" + a.rotors(sf.rotor).name() + "'");
    }
    sf.rotor = i;
    rs.surfaces.push_back(s);
  }
  if (r.has_blades()) {
    if (r.blades() < r.surfaces_size()) {
      checks.Fail(path + ".blades", std::to_string(r.blades()) + " blades, fewer than the " +
                                        std::to_string(r.surfaces_size()) +
                                        " surfaces it lists; expected at least that many");
    }
    rs.load_factor = static_cast<double>(r.blades()) / std::max(1, r.surfaces_size());
  }
  return rs;
}

}  // namespace

void AddAero(const Checks& checks, const interface::NameTable& body_names, MultibodyModel* model) {
  const sc::Model& m = checks.file().proto().model();
  if (!m.has_air()) return;
  const sc::Air& a = m.air();
  AeroModel aero;
  ReadAir(checks, a, &aero.air);
  interface::NameTable airfoil_names(checks, "airfoil");
  AddAirfoils(checks, a, &airfoil_names, &aero);
  interface::NameTable surface_names(checks, "aero surface");
  interface::NameTable beam_names(checks, "beam");
  for (size_t b = 0; b < model->beams.size(); ++b)
    beam_names.Add(ElementPath("model.beams", static_cast<int>(b)), model->beams[b].name);
  std::vector<ElasticMesh> elastic_meshes;  // built once, when a surface needs them
  for (int i = 0; i < a.surfaces_size(); ++i) {
    aero.surfaces.push_back(ReadSurface(checks, a.surfaces(i), ElementPath("model.air.surfaces", i), body_names,
                                        beam_names, airfoil_names, *model, &surface_names, &elastic_meshes));
  }
  interface::NameTable rotor_names(checks, "rotor");
  for (int i = 0; i < a.rotors_size(); ++i) {
    aero.rotors.push_back(ReadRotor(checks, a, i, body_names, surface_names, *model, &rotor_names, &aero));
  }
  model->aero = std::move(aero);
}

}  // namespace cosim::smooth
