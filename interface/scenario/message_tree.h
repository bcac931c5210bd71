#pragma once
// A scenario message walked by reflection: the field paths of its parts and the messages below
// one. Shared by the readers that rewrite a scenario in place when it is read (patterns, frames,
// station files) and by the validators' error places.
#include <google/protobuf/message.h>

#include <string>
#include <vector>

namespace cosim::interface {

// The field path of element `index` of a repeated field: ElementPath("model.bodies", 2) is
// "model.bodies[2]".
std::string ElementPath(const std::string& list, int index);

// The field path of `field` under `prefix`: "model" and "bodies" give "model.bodies", "" and
// "model" give "model".
inline std::string FieldPath(const std::string& prefix, const std::string& field) {
  return prefix.empty() ? field : prefix + "." + field;
}

// fn(child, child_path) for every message directly below `m` (singular fields and list
// elements), `path` being m's own field path.
template <class F>
void ForEachChild(google::protobuf::Message* m, const std::string& path, F&& fn) {
  namespace pb = google::protobuf;
  const pb::Reflection* r = m->GetReflection();
  std::vector<const pb::FieldDescriptor*> fields;
  r->ListFields(*m, &fields);
  for (const pb::FieldDescriptor* f : fields) {
    if (f->cpp_type() != pb::FieldDescriptor::CPPTYPE_MESSAGE) continue;
    const std::string field = FieldPath(path, f->name());
    if (f->is_repeated()) {
      for (int i = 0; i < r->FieldSize(*m, f); ++i) fn(r->MutableRepeatedMessage(m, f, i), ElementPath(field, i));
    } else {
      fn(r->MutableMessage(m, f), field);
    }
  }
}

}  // namespace cosim::interface
