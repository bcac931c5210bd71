#include "interface/scenario/contact_view.h"

#include <set>

#include "interface/scenario/scenario_file.h"

namespace cosim::interface {

namespace {

namespace pb = google::protobuf;

// What the view keeps of the smooth model: per list (of model, or of model.air), the fields kept
// on each of its elements. The rest of these elements, and of model.air, is dropped. Read by
// ReduceToContactView and OutsideContactView alike.
struct KeptList {
  std::vector<std::string> path;  // {"bodies"}, or {"air", "surfaces"}
  std::set<std::string> fields;
};
const std::vector<KeptList>& Kept() {
  static const std::vector<KeptList> kept{
      {{"bodies"}, {"name"}},
      {{"joints"}, {"name"}},
      {{"elastic_bodies"}, {"name"}},
      {{"forces"}, {"name"}},
      {{"beams"}, {"name", "elements", "nodes_per_element"}},  // the names of a beam's node bodies
      {{"air", "surfaces"}, {"name"}},
      {{"air", "rotors"}, {"name"}},
  };
  return kept;
}

// Clears every field of `m` whose name is not in `kept`.
void KeepOnly(pb::Message* m, const std::set<std::string>& kept) {
  std::vector<const pb::FieldDescriptor*> fields;
  m->GetReflection()->ListFields(*m, &fields);
  for (const pb::FieldDescriptor* f : fields) {
    if (kept.count(f->name()) == 0) m->GetReflection()->ClearField(m, f);
  }
}

}  // namespace

void ReduceToContactView(scenario::Model* model) {
  if (model->has_air()) KeepOnly(model->mutable_air(), {"surfaces", "rotors"});
  for (const KeptList& list : Kept()) {
    pb::Message* owner = model;
    if (list.path.size() == 2) {
      if (!model->has_air()) continue;
      owner = model->mutable_air();
    }
    const pb::FieldDescriptor* f = owner->GetDescriptor()->FindFieldByName(list.path.back());
    const pb::Reflection* r = owner->GetReflection();
    for (int i = 0; i < r->FieldSize(*owner, f); ++i) KeepOnly(r->MutableRepeatedMessage(owner, f, i), list.fields);
  }
}

bool OutsideContactView(const std::vector<PathSegment>& segments) {
  // A whole element or list given as a message is applied, then reduced with the rest.
  if (segments.size() < 3 || segments[0].field != "model") return false;
  for (const KeptList& list : Kept()) {
    bool in_list = true;
    for (size_t k = 0; k < list.path.size() && in_list; ++k) {
      in_list = k + 1 < segments.size() && segments[k + 1].field == list.path[k];
    }
    if (!in_list) continue;
    const size_t field = 1 + list.path.size();  // the element's field, after the list's path
    if (segments.size() <= field) return false;
    return !(segments.size() == field + 1 && list.fields.count(segments[field].field) != 0);
  }
  return segments[1].field == "air";  // the air's other fields (density, wind, airwake, …)
}

}  // namespace cosim::interface
