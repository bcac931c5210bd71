#include "interface/scenario/reference_frames.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <map>
#include <vector>

#include "interface/scenario/checks.h"
#include "interface/scenario/message_tree.h"

namespace cosim::interface {

namespace {

namespace pb = google::protobuf;

Eigen::Vector3d RotationVector(const Eigen::Matrix3d& rotation) {
  const Eigen::AngleAxisd aa(rotation);
  return aa.angle() * aa.axis();
}

// (A non-finite rotation vector gives a non-finite matrix, never the identity: `angle > 0` was
// false for a NaN, and a template's [nan, 0.1745, 0] became "no rotation".)
Eigen::Matrix3d RotationMatrix(const Eigen::Vector3d& v) {
  const double angle = v.norm();
  return angle == 0.0 ? Eigen::Matrix3d::Identity() : Eigen::AngleAxisd(angle, v / angle).toRotationMatrix();
}

// The element's `reference` field, or nullptr if its message has none.
const pb::FieldDescriptor* ReferenceField(const pb::Message& m) {
  const pb::FieldDescriptor* f = m.GetDescriptor()->FindFieldByName("reference");
  return f != nullptr && f->cpp_type() == pb::FieldDescriptor::CPPTYPE_STRING && !f->is_repeated() ? f : nullptr;
}

bool SetsReference(const pb::Message& m) {
  const pb::FieldDescriptor* f = ReferenceField(m);
  return f != nullptr && m.GetReflection()->HasField(m, f);
}

// The message at field path `path` ("model.bodies[5]", "coupling.processes[0]") below `root`,
// or nullptr.
pb::Message* FindMessage(pb::Message* root, const std::string& path) {
  pb::Message* m = root;
  size_t at = 0;
  while (m != nullptr && at < path.size()) {
    const size_t end = std::min(path.find('.', at), path.size());
    std::string part = path.substr(at, end - at);
    int index = -1;
    if (const size_t open = part.find('['); open != std::string::npos) {
      index = std::stoi(part.substr(open + 1));
      part = part.substr(0, open);
    }
    const pb::FieldDescriptor* f = m->GetDescriptor()->FindFieldByName(part);
    if (f == nullptr || f->cpp_type() != pb::FieldDescriptor::CPPTYPE_MESSAGE) return nullptr;
    const pb::Reflection* r = m->GetReflection();
    if (f->is_repeated()) {
      if (index < 0 || index >= r->FieldSize(*m, f)) return nullptr;
      m = r->MutableRepeatedMessage(m, f, index);
    } else {
      m = r->MutableMessage(m, f);
    }
    at = end + 1;
  }
  return m;
}

class Resolver {
 public:
  Resolver(scenario::Scenario* proto, const std::function<std::optional<CopyTurn>(const std::string&)>& copy_pose,
           const std::vector<std::pair<std::string, CopyTurn>>& deferred,
           const std::function<void(const std::string&, const std::string&)>& fail)
      : proto_(proto), copy_pose_(copy_pose), deferred_(deferred), fail_(fail) {}

  void Run() {
    scenario::Model* model = proto_->mutable_model();
    for (int i = 0; i < model->references_size(); ++i) {
      const std::string& name = model->references(i).name();
      const std::string path = ElementPath("model.references", i);
      if (name.empty()) fail_(path + ".name", "missing; a frame is used by its name (reference: \"NAME\")");
      if (!index_.emplace(name, i).second) {
        fail_(path + ".name", "'" + name + "' names " + ElementPath("model.references", index_[name]) + " already");
      }
      names_ += (names_.empty() ? "" : ", ") + name;
    }
    global_.resize(model->references_size());
    state_.assign(model->references_size(), kUnvisited);
    for (int i = 0; i < model->references_size(); ++i) Resolve(i);
    // The copies of patterns with a frame: their elements not written in a frame, turned about
    // the frame's axis now that it is known (their frames were placed by Resolve, the elements
    // written in one are by Place).
    for (const auto& [path, turn] : deferred_) {
      if (path.rfind("model.references[", 0) == 0) continue;
      pb::Message* element = FindMessage(proto_, path);
      if (element != nullptr && !SetsReference(*element)) TransformGeometry(element, GlobalTurn(turn), true);
    }
    // Every frame now global: its parent is dropped so that reading the result again is the same.
    for (int i = 0; i < model->references_size(); ++i) {
      scenario::Reference* r = model->mutable_references(i);
      r->clear_reference();
      r->clear_position();
      r->clear_rotation();
      for (int c = 0; c < 3; ++c) r->add_position(global_[i].translation(c));
      const Eigen::Vector3d v = RotationVector(global_[i].rotation);
      for (int c = 0; c < 3; ++c) r->add_rotation(v(c));
    }
    Place(proto_, "");
  }

 private:
  enum State { kUnvisited, kResolving, kDone };

  Eigen::Vector3d Vector3(const pb::RepeatedField<double>& v, const std::string& path) const {
    if (v.empty()) return Eigen::Vector3d::Zero();
    if (v.size() != 3) fail_(path, "expected [x, y, z], got " + std::to_string(v.size()) + " values");
    return Eigen::Vector3d(v[0], v[1], v[2]);
  }

  // The index of frame `name`, named at field `path`.
  int Find(const std::string& name, const std::string& path) const {
    const auto it = index_.find(name);
    if (it == index_.end()) {
      fail_(path, "'" + name + "' is not a frame; model.references defines " + (names_.empty() ? "none" : names_));
    }
    return it->second;
  }

  // A copy's turn in global axes: F ∘ turn ∘ F⁻¹ for a pattern written in frame F (outside the
  // patterns, resolved first), the turn itself for one in global axes.
  Pose GlobalTurn(const CopyTurn& turn) {
    if (turn.frame.empty()) return turn.turn;
    const int frame = Find(turn.frame, turn.pattern + ".reference");
    if (copy_pose_(ElementPath("model.references", frame))) {
      fail_(turn.pattern + ".reference", "'" + turn.frame +
                                             "' is a frame of a pattern's copy; a pattern turns its copies about "
                                             "a frame outside the patterns (the hub's, a yoke's)");
    }
    Resolve(frame);
    return global_[frame] * turn.turn * global_[frame].Inverse();
  }

  // The map from P's frame to the global one for an element M at `path` written in P
  // (reference_frames.h): global(P), turned from the template's view if M is in a copy.
  Pose FrameFor(const std::string& path, int parent) {
    const std::optional<CopyTurn> turn = copy_pose_(path);
    if (!turn) return global_[parent];
    const std::optional<CopyTurn> parent_turn = copy_pose_(ElementPath("model.references", parent));
    if (!parent_turn && turn->frame.empty()) RequireTurnsWithCopies(path, parent, *turn);
    const Pose parent_inverse = parent_turn ? GlobalTurn(*parent_turn).Inverse() : Pose{};
    return GlobalTurn(*turn) * parent_inverse * global_[parent];
  }

  // A copy turned about a global axis that hangs on a frame P outside it: only right if P turns
  // with the copies, its axes keeping the pattern's axis and its origin on it (a hub frame at the
  // shaft, untilted). A tilted hub or a yoke at a teeter angle would give a cone or a V.
  void RequireTurnsWithCopies(const std::string& path, int parent, const CopyTurn& turn) const {
    const Pose& P = global_[parent];
    const double scale = std::max(1.0, (P.translation - turn.origin).norm());
    const bool axis_kept = (P.rotation * turn.axis - turn.axis).norm() <= 1e-9;
    const bool on_axis = (P.translation - turn.origin).cross(turn.axis).norm() <= 1e-9 * scale;
    if (axis_kept && on_axis) return;
    const std::string name = proto_->model().references(parent).name();
    auto vec = [](const Eigen::Vector3d& x) {
      return "[" + FormatNumber(x(0)) + ", " + FormatNumber(x(1)) + ", " + FormatNumber(x(2)) + "]";
    };
    fail_(path + ".reference",
          "frame '" + name + "' (rotation " + vec(RotationVector(P.rotation)) + " rad, origin " + vec(P.translation) +
              " m) lies outside pattern " + turn.pattern + ", which turns its copies about the global axis " +
              vec(turn.axis) + "; the frame's " +
              (axis_kept ? "origin is off that axis" : "axes do not keep that axis") +
              ", so the copies would come out coned or bent instead of turned about the frame's own axis. Give the " +
              "pattern `reference: \"" + name + "\"` and write its axis in that frame");
  }

  void Resolve(int i) {
    if (state_[i] == kDone) return;
    const scenario::Reference& r = proto_->model().references(i);
    const std::string path = ElementPath("model.references", i);
    if (state_[i] == kResolving) {
      std::string cycle = r.name();
      for (auto it = chain_.rbegin(); it != chain_.rend() && *it != i; ++it) {
        cycle = proto_->model().references(*it).name() + " → " + cycle;
      }
      fail_(path + ".reference", "frames placed relative to each other in a cycle: " + r.name() + " → " + cycle);
    }
    state_[i] = kResolving;
    chain_.push_back(i);
    const Pose local{RotationMatrix(Vector3(r.rotation(), path + ".rotation")),
                     Vector3(r.position(), path + ".position")};
    if (r.has_reference()) {
      const int parent = Find(r.reference(), path + ".reference");
      Resolve(parent);
      global_[i] = FrameFor(path, parent) * local;
    } else if (const std::optional<CopyTurn> turn = copy_pose_(path); turn && !turn->frame.empty()) {
      global_[i] = GlobalTurn(*turn) * local;  // global, in a copy of a pattern with a frame
    } else {
      global_[i] = local;  // global; a pattern has turned it with its copy already
    }
    chain_.pop_back();
    state_[i] = kDone;
  }

  // Every element below `m` (at field path `path`) that is written in a frame, placed globally.
  void Place(pb::Message* m, const std::string& path) {
    if (m->GetDescriptor() == scenario::Reference::descriptor()) return;  // resolved above
    if (SetsReference(*m)) {
      const pb::FieldDescriptor* field = ReferenceField(*m);
      const pb::Reflection* r = m->GetReflection();
      const int parent = Find(r->GetString(*m, field), FieldPath(path, "reference"));
      // A body's (or node's) left-out position and rotation are the frame's origin and orientation.
      for (const char* name : {"position", "rotation"}) {
        const pb::FieldDescriptor* f = m->GetDescriptor()->FindFieldByName(name);
        if (f == nullptr || !f->is_repeated() || f->cpp_type() != pb::FieldDescriptor::CPPTYPE_DOUBLE) continue;
        if (f->options().GetExtension(scenario::geometry) == scenario::GEOMETRY_NONE || r->FieldSize(*m, f) != 0)
          continue;
        for (int c = 0; c < 3; ++c) r->AddDouble(m, f, 0.0);
      }
      TransformGeometry(m, FrameFor(path, parent), false);
      r->ClearField(m, field);
      return;
    }
    ForEachChild(m, path, [this](pb::Message* child, const std::string& at) { Place(child, at); });
  }

  scenario::Scenario* proto_;
  const std::function<std::optional<CopyTurn>(const std::string&)>& copy_pose_;
  const std::vector<std::pair<std::string, CopyTurn>>& deferred_;
  const std::function<void(const std::string&, const std::string&)>& fail_;
  std::map<std::string, int> index_;
  std::string names_;  // in definition order, "hub, hinge1, …"
  std::vector<Pose> global_;
  std::vector<State> state_;
  std::vector<int> chain_;  // the frames being resolved, outermost first
};

}  // namespace

Pose Pose::operator*(const Pose& inner) const {
  return Pose{rotation * inner.rotation, rotation * inner.translation + translation};
}

Pose Pose::Inverse() const { return Pose{rotation.transpose(), -(rotation.transpose() * translation)}; }

Pose RotationAbout(const Eigen::Vector3d& v, const Eigen::Vector3d& origin) {
  const Eigen::Matrix3d R = RotationMatrix(v);
  return Pose{R, origin - R * origin};
}

void TransformGeometry(pb::Message* message, const Pose& pose, bool skip_referenced) {
  ForEachChild(message, "", [&](pb::Message* child, const std::string&) {
    if (!(skip_referenced && SetsReference(*child))) TransformGeometry(child, pose, skip_referenced);
  });
  const pb::Reflection* r = message->GetReflection();
  std::vector<const pb::FieldDescriptor*> fields;
  r->ListFields(*message, &fields);
  for (const pb::FieldDescriptor* f : fields) {
    if (f->cpp_type() != pb::FieldDescriptor::CPPTYPE_DOUBLE || !f->is_repeated()) continue;
    const scenario::Geometry g = f->options().GetExtension(scenario::geometry);
    if (g == scenario::GEOMETRY_NONE) continue;
    const int n = r->FieldSize(*message, f);
    for (int i = 0; i + 2 < n; i += 3) {
      Eigen::Vector3d v(r->GetRepeatedDouble(*message, f, i), r->GetRepeatedDouble(*message, f, i + 1),
                        r->GetRepeatedDouble(*message, f, i + 2));
      if (g == scenario::POINT) {
        v = pose.rotation * v + pose.translation;
      } else if (g == scenario::DIRECTION) {
        v = pose.rotation * v;
      } else {
        v = RotationVector(pose.rotation * RotationMatrix(v));
      }
      for (int c = 0; c < 3; ++c) r->SetRepeatedDouble(message, f, i + c, v(c));
    }
  }
}

void ResolveReferences(scenario::Scenario* proto,
                       const std::function<std::optional<CopyTurn>(const std::string&)>& copy_pose,
                       const std::vector<std::pair<std::string, CopyTurn>>& deferred,
                       const std::function<void(const std::string&, const std::string&)>& fail) {
  if (!proto->has_model()) return;
  Resolver(proto, copy_pose, deferred, fail).Run();
}

}  // namespace cosim::interface
