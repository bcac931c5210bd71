#include "interface/scenario/contact_view.h"

#include <set>

#include "interface/scenario/scenario_file.h"

namespace cosim::interface {

namespace {

namespace sc = cosim::scenario;

// Each element of `list` replaced by its name alone.
template <typename Element>
void KeepNames(google::protobuf::RepeatedPtrField<Element>* list) {
  for (Element& e : *list) {
    if (!e.has_name()) {
      e.Clear();
      continue;
    }
    std::string name = e.name();
    e.Clear();
    e.set_name(std::move(name));
  }
}

}  // namespace

void ReduceToContactView(sc::Model* model) {
  KeepNames(model->mutable_bodies());
  KeepNames(model->mutable_joints());
  KeepNames(model->mutable_elastic_bodies());
  KeepNames(model->mutable_forces());
  for (sc::Beam& beam : *model->mutable_beams()) {
    sc::Beam kept;
    if (beam.has_name()) kept.set_name(beam.name());
    if (beam.has_elements()) kept.set_elements(beam.elements());
    if (beam.has_nodes_per_element()) kept.set_nodes_per_element(beam.nodes_per_element());
    beam = std::move(kept);
  }
  if (model->has_air()) {
    sc::Air kept;
    *kept.mutable_surfaces() = model->air().surfaces();
    *kept.mutable_rotors() = model->air().rotors();
    KeepNames(kept.mutable_surfaces());
    KeepNames(kept.mutable_rotors());
    *model->mutable_air() = std::move(kept);
  }
}

bool OutsideContactView(const std::vector<PathSegment>& segments) {
  // A whole element or list given as a message is applied, then reduced with the rest.
  if (segments.size() < 3 || segments[0].field != "model") return false;
  const std::string& list = segments[1].field;
  if (list == "air") {
    // model.air.surfaces[k].name and model.air.rotors[k].name are kept, nothing else.
    return !(segments.size() == 4 && (segments[2].field == "surfaces" || segments[2].field == "rotors") &&
             segments[3].field == "name");
  }
  static const std::set<std::string> reduced{"bodies", "joints", "elastic_bodies", "forces", "beams"};
  if (reduced.count(list) == 0) return false;
  const std::string& field = segments[2].field;
  if (field == "name" && segments.size() == 3) return false;
  if (list == "beams" && segments.size() == 3 && (field == "elements" || field == "nodes_per_element")) return false;
  return true;
}

}  // namespace cosim::interface
