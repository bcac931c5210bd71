#include "smooth_solver/simulation/smooth_probes.h"

#include <map>
#include <set>

namespace cosim::smooth {

using interface::Checks;
using interface::ElementPath;
namespace sc = cosim::scenario;
using Kind = SmoothProbe::Kind;

namespace {

// What a probe's entity names.
enum class Entity {
  kNone,     // the whole system: no entity
  kBody,     // a rigid body (or a beam node)
  kJoint,    // a joint; REACTION_* also an elastic body's clamp
  kBeam,     // a beam
  kElastic,  // a hex27 body; DISPLACEMENT also a body, STRAIN_ENERGY also a beam
  kSurface,  // an aero surface
  kRotor,    // a rotor (inflow)
  kStop,     // a continuous contact or joint stop
};

struct Rule {
  sc::Probe::Quantity quantity;
  Kind kind;
  Entity entity;
  bool vector;   // x, y, z components and a norm
  bool frame;    // may be expressed in a body's frame
  bool station;  // takes a station (span coordinate)
};

// The smooth solver's quantities, in the order its messages list them.
constexpr Rule kRules[] = {
    {sc::Probe::POSITION, Kind::kPosition, Entity::kBody, true, true, false},
    {sc::Probe::VELOCITY, Kind::kVelocity, Entity::kBody, true, true, false},
    {sc::Probe::ACCELERATION, Kind::kAcceleration, Entity::kBody, true, true, false},
    {sc::Probe::ANGULAR_VELOCITY, Kind::kAngularVelocity, Entity::kBody, true, true, false},
    {sc::Probe::JOINT_COORDINATE, Kind::kJointCoordinate, Entity::kJoint, false, false, false},
    {sc::Probe::JOINT_SPEED, Kind::kJointSpeed, Entity::kJoint, false, false, false},
    {sc::Probe::REACTION_FORCE, Kind::kReactionForce, Entity::kJoint, true, true, false},
    {sc::Probe::REACTION_MOMENT, Kind::kReactionMoment, Entity::kJoint, true, true, false},
    {sc::Probe::KINETIC_ENERGY, Kind::kKinetic, Entity::kNone, false, false, false},
    {sc::Probe::POTENTIAL_ENERGY, Kind::kPotential, Entity::kNone, false, false, false},
    {sc::Probe::TOTAL_ENERGY, Kind::kTotal, Entity::kNone, false, false, false},
    {sc::Probe::CONSTRAINT_VIOLATION, Kind::kViolation, Entity::kNone, false, false, false},
    {sc::Probe::DISPLACEMENT, Kind::kDisplacement, Entity::kElastic, true, true, false},
    {sc::Probe::STRAIN_ENERGY, Kind::kStrainEnergy, Entity::kElastic, false, false, false},
    {sc::Probe::ROTATION, Kind::kRotation, Entity::kBody, true, true, false},
    {sc::Probe::SECTION_FORCE, Kind::kSectionForce, Entity::kBeam, true, false, true},
    {sc::Probe::SECTION_MOMENT, Kind::kSectionMoment, Entity::kBeam, true, false, true},
    {sc::Probe::AERO_ANGLE_OF_ATTACK, Kind::kAeroAlpha, Entity::kSurface, false, false, true},
    {sc::Probe::AERO_FORCE, Kind::kAeroForce, Entity::kSurface, true, false, true},
    {sc::Probe::AERO_MOMENT, Kind::kAeroMoment, Entity::kSurface, false, false, true},
    {sc::Probe::AERO_MACH, Kind::kAeroMach, Entity::kSurface, false, false, true},
    {sc::Probe::ROTOR_THRUST, Kind::kRotorThrust, Entity::kRotor, false, false, false},
    {sc::Probe::ROTOR_TORQUE, Kind::kRotorTorque, Entity::kRotor, false, false, false},
    {sc::Probe::INFLOW_RATIO, Kind::kInflowRatio, Entity::kRotor, false, false, false},
    {sc::Probe::INDUCED_VELOCITY, Kind::kInducedVelocity, Entity::kRotor, false, false, false},
    {sc::Probe::CONTACT_FORCE, Kind::kContactForce, Entity::kStop, false, false, false},
};

// "A, B or C" ("and" for `last` = " and ") of the quantities whose rule passes `keep`.
template <typename Keep>
std::string QuantityList(Keep keep, const char* last) {
  std::vector<std::string> names;
  for (const Rule& r : kRules) {
    if (keep(r)) names.push_back(sc::Probe::Quantity_Name(r.quantity));
  }
  std::string out;
  for (size_t i = 0; i < names.size(); ++i) out += (i == 0 ? "" : i + 1 == names.size() ? last : ", ") + names[i];
  return out;
}

// The model's entities by name, one table per kind of entity.
struct Entities {
  std::map<std::string, int> body, joint, beam, elastic, surface, rotor, stop;
  Entities(const MultibodyModel& model, const std::vector<ElasticBodySpec>& elastic_bodies) {
    auto index = [](const auto& items, std::map<std::string, int>* out) {
      for (size_t i = 0; i < items.size(); ++i) (*out)[items[i].name] = static_cast<int>(i);
    };
    index(model.bodies, &body);
    index(model.joints, &joint);
    index(model.beams, &beam);
    index(elastic_bodies, &elastic);
    index(model.aero.surfaces, &surface);
    index(model.aero.rotors, &rotor);
    for (size_t f = 0; f < model.forces.size(); ++f) {
      const auto kind = model.forces[f].kind;
      if (kind == ForceSpec::Kind::kContact || kind == ForceSpec::Kind::kJointStop)
        stop[model.forces[f].name] = static_cast<int>(f);
    }
  }
};

// The probe's entity in `table`, or InputError listing the known ones.
int Find(const Checks& checks, const std::string& path, const sc::Probe& p, const std::map<std::string, int>& table,
         const char* kind) {
  auto it = table.find(p.entity());
  if (it == table.end()) {
    std::string known;
    for (const auto& [name, index] : table) known += (known.empty() ? "" : ", ") + name;
    checks.Fail(path + ".entity",
                std::string("no ") + kind + " named '" + p.entity() + "'" + (known.empty() ? "" : "; known: " + known));
  }
  return it->second;
}

// The station of a section probe, within [start, end] of `what` ("outside WHAT (LABEL start
// to end m)").
double Station(const Checks& checks, const std::string& path, const sc::Probe& p, double start, double end,
               const std::string& what, const std::string& label) {
  checks.Require(path + ".station", p.has_station(), "the section's span coordinate in m");
  if (p.station() < start || p.station() > end) {
    checks.Fail(path + ".station", interface::FormatNumber(p.station()) + " m is outside " + what + " (" + label +
                                       interface::FormatNumber(start) + " to " + interface::FormatNumber(end) + " m)");
  }
  return p.station();
}

// The probe's entity (and the kind it refines to: a body's DISPLACEMENT, a beam's
// STRAIN_ENERGY, an elastic body's REACTION_*), checked against the model.
void ResolveEntity(const Checks& checks, const std::string& path, const sc::Probe& p, const Rule& rule,
                   const MultibodyModel& model, const std::vector<ElasticBodySpec>& elastic, const Entities& names,
                   SmoothProbe* spec) {
  const std::string& entity = p.entity();
  switch (rule.entity) {
    case Entity::kNone:
      if (!entity.empty()) checks.Fail(path + ".entity", "this quantity is for the whole system; leave entity out");
      break;
    case Entity::kBody:
      spec->index = Find(checks, path, p, names.body, "body");
      break;
    case Entity::kJoint: {
      const bool reaction = rule.kind == Kind::kReactionForce || rule.kind == Kind::kReactionMoment;
      if (reaction && names.elastic.count(entity) != 0) {  // an elastic body's clamp
        spec->kind = rule.kind == Kind::kReactionForce ? Kind::kClampForce : Kind::kClampMoment;
        spec->index = names.elastic.at(entity);
        break;
      }
      spec->index = Find(checks, path, p, names.joint, "joint");
      const JointType type = model.joints[static_cast<size_t>(spec->index)].type;
      if (!reaction && type != JointType::kRevolute && type != JointType::kPrismatic) {
        checks.Fail(path + ".entity", "joint '" + entity + "' has no single coordinate (revolute or prismatic only)");
      }
      break;
    }
    case Entity::kBeam: {
      spec->index = Find(checks, path, p, names.beam, "beam");
      const BeamModel& beam = model.beams[static_cast<size_t>(spec->index)];
      spec->station = Station(checks, path, p, beam.span_start, beam.span_end, "beam '" + beam.name + "'", "span ");
      break;
    }
    case Entity::kElastic:
      if (rule.kind == Kind::kDisplacement && names.elastic.count(entity) == 0 && names.body.count(entity) != 0) {
        spec->kind = Kind::kBodyDisplacement;  // of a body (a beam node, a rigid body): from its initial position
        spec->index = names.body.at(entity);
        break;
      }
      if (rule.kind == Kind::kStrainEnergy && names.beam.count(entity) != 0) {
        spec->kind = Kind::kBeamStrainEnergy;
        spec->index = names.beam.at(entity);
        break;
      }
      spec->index = Find(checks, path, p, names.elastic, "elastic body");
      if (rule.kind == Kind::kDisplacement) {
        checks.Require(path + ".point", p.has_point(), "a node index, \"tip_centre\" or \"root_centre\"");
        spec->node = elastic[static_cast<size_t>(spec->index)].FindPoint(checks, path + ".point", p.point());
      }
      break;
    case Entity::kSurface: {
      spec->index = Find(checks, path, p, names.surface, "aero surface");
      const auto& st = model.aero.surfaces[static_cast<size_t>(spec->index)].stations;
      spec->station = Station(checks, path, p, st.front().s, st.back().s, "the loaded span of '" + entity + "'", "");
      break;
    }
    case Entity::kRotor:
      spec->index = Find(checks, path, p, names.rotor, "rotor");
      break;
    case Entity::kStop:
      spec->index = Find(checks, path, p, names.stop, "continuous contact or joint stop");
      break;
  }
}

}  // namespace

std::vector<SmoothProbe> ReadSmoothProbes(const Checks& checks, const interface::ScenarioFile& file, bool coupled,
                                          const MultibodyModel& model, const std::vector<ElasticBodySpec>& elastic) {
  const Entities names(model, elastic);
  interface::NameTable probe_names(checks, "probe");
  const sc::Output& output = file.proto().output();
  // In a coupled run, probes of contact nodes and contacts are the contact process's.
  std::set<std::string> contact_entities;
  if (coupled) {
    for (const auto& node : file.proto().model().contact_nodes()) {
      contact_entities.insert(node.name());
      for (const auto& c : node.contacts()) contact_entities.insert(node.name() + "/" + c.obstacle());
    }
  }
  std::vector<SmoothProbe> probes;
  for (int i = 0; i < output.probes_size(); ++i) {
    const sc::Probe& p = output.probes(i);
    const std::string path = ElementPath("output.probes", i);
    if (contact_entities.count(p.entity()) != 0) continue;
    if (p.name() == "time") checks.Fail(path + ".name", "'time' is the first column already; choose another name");
    SmoothProbe spec;
    spec.name = probe_names.Declare(path + ".name", p.has_name(), p.name());
    const Rule* rule = nullptr;
    for (const Rule& r : kRules) {
      if (r.quantity == p.quantity()) rule = &r;
    }
    if (rule == nullptr) {
      checks.Fail(path + ".quantity", "the smooth solver records " +
                                          QuantityList([](const Rule&) { return true; }, " or ") + ", got " +
                                          sc::Probe::Quantity_Name(p.quantity()));
    }
    spec.kind = rule->kind;
    if (p.has_frame()) {
      if (!rule->frame) {
        checks.Fail(path + ".frame", "only " + QuantityList([](const Rule& r) { return r.frame; }, " and ") +
                                         " can be expressed in a body's frame");
      }
      if (p.frame() != "ground") {
        auto it = names.body.find(p.frame());
        if (it == names.body.end()) checks.Fail(path + ".frame", "no body named '" + p.frame() + "'");
        spec.frame = it->second;
      }
    }
    if (p.has_station() && !rule->station) {
      checks.Fail(path + ".station",
                  "only " + QuantityList([](const Rule& r) { return r.station; }, " and ") + " probes take a station");
    }
    ResolveEntity(checks, path, p, *rule, model, elastic, names, &spec);
    spec.component = interface::ProbeComponent(checks, path, p, rule->vector);
    probes.push_back(spec);
  }
  return probes;
}

}  // namespace cosim::smooth
