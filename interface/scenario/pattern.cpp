#include "interface/scenario/pattern.h"

#include <Eigen/Geometry>
#include <cmath>
#include <map>
#include <numbers>

#include "interface/scenario/message_tree.h"

namespace cosim::interface {

namespace {

namespace pb = google::protobuf;

void ReplaceAll(std::string* s, const std::string& from, const std::string& to) {
  for (size_t at = s->find(from); at != std::string::npos; at = s->find(from, at + to.size()))
    s->replace(at, from.size(), to);
}

// `each` may set lists (repeated messages) inside containers (singular messages) only.
void CheckOnlyLists(const pb::Message& m, const std::string& path,
                    const std::function<void(const std::string&, const std::string&)>& fail) {
  std::vector<const pb::FieldDescriptor*> fields;
  m.GetReflection()->ListFields(m, &fields);
  for (const pb::FieldDescriptor* f : fields) {
    const std::string p = FieldPath(path, f->name());
    if (f->cpp_type() == pb::FieldDescriptor::CPPTYPE_MESSAGE && !f->is_repeated()) {
      CheckOnlyLists(m.GetReflection()->GetMessage(m, f), p, fail);
    } else if (!(f->cpp_type() == pb::FieldDescriptor::CPPTYPE_MESSAGE && f->is_repeated())) {
      fail(p,
           "a pattern repeats list elements (bodies, joints, beams, forces, surfaces, contact nodes, probes, …); "
           "set this field in the scenario itself");
    }
  }
}

// Every string of `m` (and below) with "{k}" replaced.
void Substitute(pb::Message* m, const std::string& k) {
  const pb::Reflection* r = m->GetReflection();
  std::vector<const pb::FieldDescriptor*> fields;
  r->ListFields(*m, &fields);
  for (const pb::FieldDescriptor* f : fields) {
    if (f->cpp_type() == pb::FieldDescriptor::CPPTYPE_STRING) {
      if (f->is_repeated()) {
        for (int i = 0; i < r->FieldSize(*m, f); ++i) {
          std::string v = r->GetRepeatedString(*m, f, i);
          ReplaceAll(&v, "{k}", k);
          r->SetRepeatedString(m, f, i, v);
        }
      } else {
        std::string v = r->GetString(*m, f);
        ReplaceAll(&v, "{k}", k);
        r->SetString(m, f, v);
      }
    }
  }
  ForEachChild(m, "", [&](pb::Message* child, const std::string&) { Substitute(child, k); });
}

// Appends the lists of `from` to those of `to`, recording where each element came from.
void Append(const pb::Message& from, pb::Message* to, const std::string& source, const std::string& target,
            const std::string& pattern, int copy, const CopyTurn& turn, std::vector<PatternOrigin>* origins) {
  const pb::Reflection* rf = from.GetReflection();
  const pb::Reflection* rt = to->GetReflection();
  std::vector<const pb::FieldDescriptor*> fields;
  rf->ListFields(from, &fields);
  for (const pb::FieldDescriptor* f : fields) {
    const std::string s = FieldPath(source, f->name()), t = FieldPath(target, f->name());
    if (!f->is_repeated()) {
      Append(rf->GetMessage(from, f), rt->MutableMessage(to, f), s, t, pattern, copy, turn, origins);
      continue;
    }
    for (int i = 0; i < rf->FieldSize(from, f); ++i) {
      const int at = rt->FieldSize(*to, f);
      rt->AddMessage(to, f)->CopyFrom(rf->GetRepeatedMessage(from, f, i));
      origins->push_back({ElementPath(t, at), ElementPath(s, i), pattern, copy, turn});
    }
  }
}

// Outside the patterns: list entries "…{NAME}…" become one entry per copy of pattern NAME.
void ExpandReferences(pb::Message* m, const std::map<std::string, int>& counts) {
  const pb::Reflection* r = m->GetReflection();
  std::vector<const pb::FieldDescriptor*> fields;
  r->ListFields(*m, &fields);
  ForEachChild(m, "", [&](pb::Message* child, const std::string&) { ExpandReferences(child, counts); });
  for (const pb::FieldDescriptor* f : fields) {
    if (f->cpp_type() != pb::FieldDescriptor::CPPTYPE_STRING || !f->is_repeated()) continue;
    std::vector<std::string> entries;
    bool changed = false;
    for (int i = 0; i < r->FieldSize(*m, f); ++i) {
      const std::string v = r->GetRepeatedString(*m, f, i);
      bool expanded = false;
      for (const auto& [name, count] : counts) {
        const std::string key = "{" + name + "}";
        if (v.find(key) == std::string::npos) continue;
        for (int k = 1; k <= count; ++k) {
          std::string e = v;
          ReplaceAll(&e, key, std::to_string(k));
          entries.push_back(e);
        }
        expanded = changed = true;
        break;
      }
      if (!expanded) entries.push_back(v);
    }
    if (!changed) continue;
    r->ClearField(m, f);
    for (const std::string& e : entries) r->AddString(m, f, e);
  }
}

}  // namespace

std::vector<PatternOrigin> ExpandPatterns(scenario::Scenario* proto,
                                          const std::function<void(const std::string&, const std::string&)>& fail) {
  std::vector<PatternOrigin> origins;
  if (proto->patterns_size() == 0) return origins;
  std::map<std::string, int> counts;
  const google::protobuf::RepeatedPtrField<scenario::Pattern> patterns = proto->patterns();
  proto->clear_patterns();
  for (int p = 0; p < patterns.size(); ++p) {
    const scenario::Pattern& pat = patterns[p];
    const std::string path = ElementPath("patterns", p);
    if (!pat.has_name() || pat.name().empty())
      fail(path + ".name", "missing; a pattern's name is what {NAME} refers to");
    for (char c : pat.name()) {
      if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') {
        fail(path + ".name", "'" + pat.name() + "' is not a name of letters, digits and '_'");
      }
    }
    if (counts.count(pat.name()) != 0) fail(path + ".name", "'" + pat.name() + "' names another pattern already");
    if (!pat.has_count() || pat.count() < 1 || pat.count() > 1000) {
      fail(path + ".count",
           "expected 1 to 1000 copies, got " + (pat.has_count() ? std::to_string(pat.count()) : "none"));
    }
    auto vector3 = [&](const google::protobuf::RepeatedField<double>& v, const std::string& field,
                       const Eigen::Vector3d& fallback) {
      if (v.empty()) return fallback;
      if (v.size() != 3) fail(path + "." + field, "expected [x, y, z], got " + std::to_string(v.size()) + " values");
      return Eigen::Vector3d(v[0], v[1], v[2]);
    };
    const Eigen::Vector3d axis = vector3(pat.axis(), "axis", Eigen::Vector3d::UnitZ());
    if (axis.norm() == 0.0) fail(path + ".axis", "is zero; expected the direction of the pattern's axis");
    const Eigen::Vector3d origin = vector3(pat.origin(), "origin", Eigen::Vector3d::Zero());
    if (pat.has_reference() && pat.reference().empty())
      fail(path + ".reference", "is empty; name the frame (model.references) the axis is written in, or leave it out");
    if (!pat.has_each()) fail(path + ".each", "missing; give the elements to repeat");
    CheckOnlyLists(pat.each(), path + ".each", fail);
    counts[pat.name()] = pat.count();
    for (int k = 1; k <= pat.count(); ++k) {
      scenario::Scenario copy = pat.each();
      Substitute(&copy, std::to_string(k));
      const double psi = pat.first_azimuth() + (k - 1) * 2.0 * std::numbers::pi / pat.count();
      // Elements written in a frame stay as they are: the frame turns (reference_frames.h). In a
      // pattern with a frame, nothing is turned yet: the frame's pose is known once every
      // override is applied (ResolveReferences turns the copy then).
      CopyTurn turn{RotationAbout(psi * axis.normalized(), origin), pat.reference(), axis.normalized(), origin, path};
      if (turn.frame.empty()) TransformGeometry(&copy, turn.turn, true);
      Append(copy, proto, path + ".each", "", pat.name(), k, turn, &origins);
    }
  }
  ExpandReferences(proto, counts);
  return origins;
}

}  // namespace cosim::interface
