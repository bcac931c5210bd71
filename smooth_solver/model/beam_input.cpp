#include "smooth_solver/model/beam_input.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace cosim::smooth {

using interface::Checks;
using interface::ElementPath;
using interface::FormatNumber;
namespace sc = cosim::scenario;

namespace {

BeamSection ReadStation(const Checks& checks, const std::string& path, const sc::BeamStation& st) {
  BeamSection s;
  s.ea = checks.Positive(path + ".ea", st.has_ea(), st.ea(), "N");
  s.ga2 = st.has_ga_chord() ? checks.Positive(path + ".ga_chord", true, st.ga_chord(), "N") : s.ea;
  s.ga3 = st.has_ga_flap() ? checks.Positive(path + ".ga_flap", true, st.ga_flap(), "N") : s.ea;
  s.gj = checks.Positive(path + ".gj", st.has_gj(), st.gj(), "N m^2");
  s.ei2 = checks.Positive(path + ".ei_flap", st.has_ei_flap(), st.ei_flap(), "N m^2");
  s.ei3 = checks.Positive(path + ".ei_lag", st.has_ei_lag(), st.ei_lag(), "N m^2");
  s.mass = checks.Positive(path + ".mass", st.has_mass(), st.mass(), "kg/m");
  s.cg2 = st.cg_chord();
  s.cg3 = st.cg_flap();
  s.tension2 = st.tension_chord();
  s.tension3 = st.tension_flap();
  const double torsion = checks.NonNegative(path + ".inertia_torsion", st.inertia_torsion(), "kg m");
  s.inertia2 = checks.NonNegative(path + ".inertia_flap", st.inertia_flap(), "kg m");
  if (s.inertia2 > torsion) {
    checks.Fail(path + ".inertia_flap", FormatNumber(s.inertia2) + " kg m is more than inertia_torsion (" +
                                            FormatNumber(torsion) + " kg m), of which it is the flapwise part");
  }
  s.inertia3 = torsion - s.inertia2;
  s.twist = st.twist();
  return s;
}

}  // namespace

// The beam's section table (stations in span order; a step is two stations at one s) and its
// loaded span.
void ReadSectionTable(const Checks& checks, const sc::Beam& b, const std::string& path, BeamModel* beam_out) {
  BeamModel& beam = *beam_out;
  if (b.stations_size() < 1) checks.Fail(path + ".stations", "a beam needs at least one station of section data");
  std::vector<double> s;
  std::vector<BeamSection> sections;
  for (int k = 0; k < b.stations_size(); ++k) {
    const std::string spath = ElementPath(path + ".stations", k);
    const sc::BeamStation& st = b.stations(k);
    checks.Require(spath + ".s", st.has_s(), "the station's span coordinate in m");
    if (!s.empty() && st.s() < s.back()) {
      checks.Fail(spath + ".s", "station out of order: s = " + FormatNumber(st.s()) +
                                    " m comes after s = " + FormatNumber(s.back()) + " m; stations must not decrease");
    }
    if (s.size() >= 2 && st.s() == s.back() && s[s.size() - 2] == st.s()) {
      checks.Fail(spath + ".s",
                  "a third station at s = " + FormatNumber(st.s()) + " m; a step is two stations at the same s");
    }
    s.push_back(st.s());
    sections.push_back(ReadStation(checks, spath, st));
  }
  beam.span_start = b.has_span_start() ? b.span_start() : s.front();
  beam.span_end = b.has_span_end() ? b.span_end() : s.back();
  if (beam.span_start < s.front() || beam.span_start > s.back()) {
    checks.Fail(path + ".span_start", FormatNumber(beam.span_start) + " m is outside the stations' range [" +
                                          FormatNumber(s.front()) + ", " + FormatNumber(s.back()) + "] m");
  }
  if (!(beam.span_end > beam.span_start) || beam.span_end > s.back()) {
    checks.Fail(path + ".span_end", FormatNumber(beam.span_end) +
                                        " m: expected in (span_start = " + FormatNumber(beam.span_start) +
                                        ", last station = " + FormatNumber(s.back()) + "] m");
  }
  beam.table = BeamTable(s, sections);
}

// The elements' ends in s, root to tip: `elements` equally long, or shared among the segments
// that element_boundaries cut the span into. Each segment gets one element, then each further
// element goes to the segment whose elements are longest (the first of equals), so the elements
// are as even as the cuts allow and each segment's are equally long.
std::vector<double> ElementEnds(const Checks& checks, const sc::Beam& b, const std::string& path,
                                const BeamModel& beam) {
  std::vector<double> cuts{beam.span_start};
  for (int i = 0; i < b.element_boundaries_size(); ++i) {
    const std::string at = ElementPath(path + ".element_boundaries", i);
    const double s = b.element_boundaries(i);
    if (!std::isfinite(s) || s <= cuts.back() || s >= beam.span_end) {
      checks.Fail(at, FormatNumber(s) + " m: expected in (" + FormatNumber(cuts.back()) + ", " +
                          FormatNumber(beam.span_end) + ") m, after " +
                          (i == 0 ? "span_start" : "the boundary before it") + " and before span_end");
    }
    cuts.push_back(s);
  }
  cuts.push_back(beam.span_end);
  const int segments = static_cast<int>(cuts.size()) - 1;
  if (b.elements() < segments) {
    checks.Fail(path + ".elements", std::to_string(b.elements()) + ": the " +
                                        std::to_string(b.element_boundaries_size()) +
                                        " element_boundaries cut the span into " + std::to_string(segments) +
                                        " segments, which need one element each at least");
  }
  std::vector<int> count(static_cast<size_t>(segments), 1);
  for (int extra = b.elements() - segments; extra > 0; --extra) {
    size_t longest = 0;
    double length = -1.0;
    for (size_t j = 0; j < count.size(); ++j) {
      const double l = (cuts[j + 1] - cuts[j]) / count[j];
      if (l > length * (1.0 + 1e-12)) {
        length = l;
        longest = j;
      }
    }
    ++count[longest];
  }
  std::vector<double> ends{beam.span_start};
  for (size_t j = 0; j < count.size(); ++j) {
    for (int e = 1; e <= count[j]; ++e) ends.push_back(cuts[j] + (cuts[j + 1] - cuts[j]) * e / count[j]);
    ends.back() = cuts[j + 1];  // (exactly on the cut)
  }
  return ends;
}

// The beam's nodes: bodies along the reference line at the elements' ends and (quadratic) their
// middles, their axes the section frames (twisted with the table), moving with the beam's initial
// velocity and angular velocity.
void AddBeamNodes(const Checks& checks, const sc::Beam& b, const std::string& path, const std::vector<double>& ends,
                  interface::NameTable* body_names, BeamModel* beam_out, MultibodyModel* model) {
  BeamModel& beam = *beam_out;
  const Eigen::Vector3d root = checks.Vector3(path + ".root", b.root(), std::nullopt);
  const Eigen::Vector3d axis = checks.Direction(path + ".axis", b.axis());
  const Eigen::Vector3d d2_0 = checks.AcrossAxis(path + ".chord", b.chord(), axis), d3_0 = axis.cross(d2_0);
  beam.d2_0 = d2_0;
  beam.d3_0 = d3_0;
  const Eigen::Vector3d v0 = checks.Vector3(path + ".velocity", b.velocity(), Eigen::Vector3d::Zero());
  const Eigen::Vector3d w0 = checks.Vector3(path + ".angular_velocity", b.angular_velocity(), Eigen::Vector3d::Zero());

  const int n = beam.nodes_per_element, ne = static_cast<int>(ends.size()) - 1, nodes = ne * (n - 1) + 1;
  for (int k = 0; k < nodes; ++k) {
    const size_t e = static_cast<size_t>(std::min(k / (n - 1), ne - 1));
    const double sk = ends[e] + (ends[e + 1] - ends[e]) * (k - static_cast<int>(e) * (n - 1)) / (n - 1);
    const double twist = beam.table.At(sk).twist;
    RigidBody node;
    node.name = beam.name + ".n" + std::to_string(k);
    body_names->Add(path + ".name", node.name);
    node.position = root + (sk - beam.span_start) * axis;
    Eigen::Matrix3d R;
    R.col(0) = axis;
    R.col(1) = std::cos(twist) * d2_0 + std::sin(twist) * d3_0;
    R.col(2) = -std::sin(twist) * d2_0 + std::cos(twist) * d3_0;
    node.orientation = Eigen::Quaterniond(R);
    node.velocity = v0 + w0.cross(node.position - root);
    node.angular_velocity = w0;
    beam.node_bodies.push_back(static_cast<int>(model->bodies.size()));
    model->bodies.push_back(node);
  }
}

// The beam's elements over its nodes: reference coordinates and the Gauss points' stiffness
// (the table sampled there: a step inside an element is smeared; element_boundaries put one on
// it).
void AddBeamElements(const std::vector<double>& ends, const MultibodyModel& model, BeamModel* beam_out) {
  BeamModel& beam = *beam_out;
  const int n = beam.nodes_per_element, ne = static_cast<int>(ends.size()) - 1;
  std::array<double, 2> xi{}, w{};
  const int gauss = BeamGaussPoints(n, &xi, &w);
  for (int e = 0; e < ne; ++e) {
    BeamElement el;
    el.s0 = ends[static_cast<size_t>(e)];
    el.length = ends[static_cast<size_t>(e) + 1] - el.s0;
    const double le = el.length;
    for (int I = 0; I < n; ++I) {
      const int body = beam.node_bodies[static_cast<size_t>(e * (n - 1) + I)];
      el.node[static_cast<size_t>(I)] = body;
      const RigidBody& nb = model.bodies[static_cast<size_t>(body)];
      const Eigen::Matrix3d R = nb.orientation.toRotationMatrix();
      el.q_ref.segment<3>(kCoordinatesPerBody * I) = nb.position;
      for (int a = 0; a < 3; ++a) el.q_ref.segment<3>(kCoordinatesPerBody * I + 3 + 3 * a) = R.col(a);
    }
    for (int g = 0; g < gauss; ++g) {
      const double sg = el.s0 + 0.5 * (xi[static_cast<size_t>(g)] + 1.0) * le;
      el.stiffness[static_cast<size_t>(g)] = SectionStiffness(beam.table.At(sg));
    }
    beam.elements.push_back(el);
  }
}

void AddBeams(const Checks& checks, interface::NameTable* body_names, MultibodyModel* model) {
  const sc::Model& m = checks.file().proto().model();
  interface::NameTable beam_names(checks, "beam");
  for (int i = 0; i < m.beams_size(); ++i) {
    const sc::Beam& b = m.beams(i);
    const std::string path = ElementPath("model.beams", i);
    BeamModel beam;
    beam.name = beam_names.Declare(path + ".name", b.has_name(), b.name());
    if (b.name() == "ground") checks.Fail(path + ".name", "'ground' is the fixed frame; choose another name");

    ReadSectionTable(checks, b, path, &beam);

    // Discretisation.
    checks.Require(path + ".elements", b.has_elements(), "the number of elements (>= 1)");
    if (b.elements() < 1 || b.elements() > 10000) {
      checks.Fail(path + ".elements", "expected 1 to 10000 elements, got " + std::to_string(b.elements()));
    }
    if (b.nodes_per_element() != 2 && b.nodes_per_element() != 3) {
      checks.Fail(path + ".nodes_per_element",
                  "expected 2 (linear) or 3 (quadratic), got " + std::to_string(b.nodes_per_element()));
    }
    beam.nodes_per_element = b.nodes_per_element();
    beam.retardation = checks.NonNegative(path + ".retardation_time", b.retardation_time(), "s");

    const std::vector<double> ends = ElementEnds(checks, b, path, beam);
    AddBeamNodes(checks, b, path, ends, body_names, &beam, model);
    AddBeamElements(ends, *model, &beam);
    model->beams.push_back(std::move(beam));
  }
}

void AddBeamClamps(const Checks& checks, const interface::NameTable& body_names, interface::NameTable* joint_names,
                   MultibodyModel* model) {
  const sc::Model& m = checks.file().proto().model();
  for (int i = 0; i < m.beams_size(); ++i) {
    const sc::Beam& b = m.beams(i);
    if (!b.has_root_body()) continue;
    const std::string path = ElementPath("model.beams", i) + ".root_body";
    const BeamModel& beam = model->beams[static_cast<size_t>(i)];
    const int body = b.root_body() == "ground" ? -1 : body_names.Find(path, b.root_body());
    if (body == beam.node_bodies.front()) checks.Fail(path, "clamps the beam's root to itself");
    Joint clamp;
    clamp.name = beam.name + ".root_clamp";
    joint_names->Add(path, clamp.name);
    clamp.type = JointType::kFixed;
    clamp.body1 = body;
    clamp.body2 = beam.node_bodies.front();
    clamp.point = model->bodies[static_cast<size_t>(clamp.body2)].position;
    model->joints.push_back(clamp);
  }
}

}  // namespace cosim::smooth
