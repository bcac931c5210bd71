#pragma once
// Quasi-steady strip theory with rotor inflow (docs/design.md "Blade aerodynamics";
// docs/reference/aero.md). Every section's kinematics are linear in the natural coordinates: its
// quarter-chord point a, three-quarter-chord point p, chordwise axis e1 (towards the leading
// edge) and upper normal e2 are fixed combinations Σ_k w_k q_k of 3-vector slots q_k of q (a
// rigid body's x, u, v, w; a beam node's x, d2, d3 weighted by the shape functions). Then, with
// the air velocity u(x, t) (wind + gusts − induced velocity along the rotor axis),
//   v = ṗ − u,  v_i = e_i · v (e3 = e1 × e2),  α = atan2(−v2, v1),  M = √(v1² + v2²)/a_s,
//   f1 = −φ (C_l v2 + C_d v1),  f2 = φ (C_l v1 − C_d v2),  f3 = −φ C_d0 v3,  φ = ½ ρ c v_p²/v_r,
//   m = ½ ρ c² v_p² C_m  (about the quarter chord, a couple along e3),
// with v_p² = v1² + v2² and the regularised v_r = √(v_p² + ε²) (the loads vanish like v_p at a
// still section). The force F = Σ f_i e_i acts at a; the couple m e3 is the virtual work of
// (m/c) e2 at a ± (c/2) e1, i.e. the generalised force Eᵀ (m e2) on e1's slots.
// Newton matrix: exact derivatives with respect to q̇ (through ṗ) and q (through the section
// frame e1, e2); the air velocity's dependence on position (a gust front's gradient, the
// induced velocity's linear part) and the rotor's inflow state are held over the step.
#include <Eigen/Core>
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "interface/scenario/time_function.h"
#include "smooth_solver/aero/airfoil.h"
#include "smooth_solver/beam/beam_model.h"
#include "smooth_solver/elastic/elastic_body.h"
#include "smooth_solver/forces/force_elements.h"

namespace cosim::smooth {

struct GustFront {
  Eigen::Vector3d front_direction = Eigen::Vector3d::UnitX(), direction = Eigen::Vector3d::UnitX();
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  double front_speed = 1.0;
  interface::TimeFunction profile;  // gust speed against the distance travelled past x
};

// A ship's airwake (proto Airwake; docs/design.md "Airwake"): the mean wind V d plus the vertical
// k(ξ) V up, ξ = d · (x − origin) the distance along the wind, or a surveyed grid in ship axes.
struct Airwake {
  enum class Form { kNone, kUniform, kLinear, kStep, kTable };
  Form form = Form::kNone;
  double speed = 0.0;                                                       // V
  double windward = 0.0, leeward = 0.0;                                     // k at the windward and leeward sides
  double length = 1.0, edge = 0.0, edge_width = 1.0;                        // LINEAR's L; STEP's edge and blend width
  interface::TimeFunction growth = interface::TimeFunction::Constant(1.0);  // the field's share at t
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d bow = Eigen::Vector3d::UnitX(), port = Eigen::Vector3d::UnitY(), up = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d along = -Eigen::Vector3d::UnitX();  // d, the direction the wind blows towards
  // kTable: the grid's distinct x and y (increasing) and its [u, v, w]/V at (xs[i], ys[j]) in
  // grid[i * ys.size() + j], ship axes.
  std::vector<double> xs, ys;
  std::vector<Eigen::Vector3d> grid;

  double Ratio(double xi) const;  // k(ξ), the vertical velocity over V
  Eigen::Vector3d Velocity(const Eigen::Vector3d& x, double t) const;
};

struct AirModel {
  double density = 1.225, speed_of_sound = 340.0, guard_speed = 0.1;
  std::array<interface::TimeFunction, 3> wind;
  std::vector<GustFront> gusts;
  Airwake airwake;
  // Velocity of the air at x, t (without induced velocity).
  Eigen::Vector3d Velocity(const Eigen::Vector3d& x, double t) const;
};

struct AeroStationSpec {
  double s = 0.0, chord = 0.0, twist = 0.0, quarter_chord = 0.0;
  int airfoil = -1;  // index into AeroModel::airfoils
};

// Where the material point X of a hex27 mesh lies: element, and the shape functions and their
// reference gradients there. False if X is in no element.
struct MeshPoint {
  int element = -1;
  std::array<double, 27> N{};
  std::array<Eigen::Vector3d, 27> grad{};  // ∇_X N_a
};
[[nodiscard]] bool LocateInMesh(const ElasticMesh& mesh, const Eigen::Vector3d& X, MeshPoint* at);

// A surface as validated from the scenario; sections are built from it (AirLoads::Section).
struct AeroSurfaceSpec {
  std::string name;
  bool on_beam = false;
  BeamModel beam;  // on_beam: a copy of the carrying beam (elements, table)
  // Body: body index and the reference line (root, axis, chord towards the leading edge) in body
  // coordinates.
  int body = -1;
  // Elastic carrier: the body's index among the elastic bodies and its reference mesh; root_b,
  // axis_b, chord_b are then global (reference configuration).
  int elastic = -1;
  ElasticMesh mesh;
  Eigen::Vector3d root_b = Eigen::Vector3d::Zero(), axis_b = Eigen::Vector3d::UnitX(),
                  chord_b = Eigen::Vector3d::UnitY();
  double upper_sign = 1.0;  // e2 = upper_sign · (rotated d3, or axis × chord)
  std::vector<AeroStationSpec> stations;
  int gauss_points = 2, segments = 10;
  int rotor = -1;
};

struct RotorSpec {
  enum class Inflow { kNone, kUniform, kPittPeters };
  std::string name;
  int hub = -1;
  Eigen::Vector3d axis_b = Eigen::Vector3d::UnitZ();  // thrust direction in hub coordinates
  double radius = 1.0, guard_tip_speed = 10.0;
  Inflow inflow = Inflow::kUniform;
  std::vector<int> surfaces;
  double load_factor = 1.0;              // blades / modelled surfaces: scales the inflow's forcing
  double induced_velocity_factor = 1.0;  // κ: UNIFORM applies κ ν_m (ν_m the momentum balance's)
};

struct AeroModel {
  AirModel air;
  std::vector<std::shared_ptr<const Airfoil>> airfoils;
  std::vector<std::string> airfoil_names;
  std::vector<AeroSurfaceSpec> surfaces;
  std::vector<RotorSpec> rotors;
  bool empty() const { return surfaces.empty(); }
};

// One integration point or probe station of a surface.
struct AeroSection {
  static constexpr int kMaxSlots = 27;
  int slots = 0;
  std::array<int, kMaxSlots> slot{};  // first coordinate of a 3-vector slot of q
  // Weights of each slot in a (quarter chord), p (three-quarter chord), e1 and e2.
  std::array<double, kMaxSlots> wa{}, wp{}, we{}, wn{};
  double s = 0.0, weight = 0.0, chord = 0.0, cd0 = 0.0;
  std::array<const Airfoil*, 2> airfoil{nullptr, nullptr};
  double blend = 0.0;  // weight of airfoil[1]
  int rotor = -1;
};

class AirLoads : public ForceElement {
 public:
  // `elastic_offset`: the first coordinate of each elastic body's nodes. The rotors' inflow is
  // read from `data.rotors` (one per rotor: rotor_count()), which AcceptStep advances.
  AirLoads(AeroModel model, std::vector<int> elastic_offset);
  size_t rotor_count() const { return model_.rotors.size(); }
  void AddForce(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, const SystemData& data,
                Eigen::Ref<Eigen::VectorXd> f) const override;
  void AddTangent(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, const SystemData& data,
                  double stiffness_scale, double damping_scale, SparseSink* sink) const override;
  void Pattern(SparseSink* sink) const override;
  bool Passive() const override { return false; }
  // Advances the rotors' inflow to the accepted state (uniform: solved anew; Pitt–Peters: one
  // implicit Euler step of its states over t − t_previous).
  void AcceptStep(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, SystemData* data) const override;

  const AeroModel& model() const { return model_; }
  // A section of surface `surface` at span coordinate s (weight 1), for probes.
  AeroSection Section(int surface, double s, double weight) const;
  struct SectionResult {
    double alpha = 0.0, mach = 0.0, moment = 0.0;           // moment per span about the quarter chord
    Eigen::Vector3d force_local = Eigen::Vector3d::Zero();  // per span, section frame
    Eigen::Vector3d force = Eigen::Vector3d::Zero(), point = Eigen::Vector3d::Zero();  // global, at a
  };
  SectionResult Evaluate(const AeroSection& section, const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t,
                         const SystemData& data) const;
  struct RotorResult {
    double thrust = 0.0, torque = 0.0, moment_x = 0.0, moment_y = 0.0;  // moments: first moments of thrust
    double inflow_ratio = 0.0, induced = 0.0, tip_speed = 0.0;
  };
  // Loads of rotor r's blades at (q, q̇, t) under its current inflow.
  RotorResult Rotor(int r, const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t,
                    const SystemData& data) const;
  size_t section_count() const { return sections_.size(); }

 private:
  // The rotor's frame and inflow, fixed over a step: in SystemData (a run's changing state).
  using RotorState = RotorInflowState;
  void UpdateFrame(int r, const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t, RotorState* s) const;
  RotorResult RotorLoads(int r, const RotorState& state, const Eigen::VectorXd& q, const Eigen::VectorXd& qdot,
                         double t) const;

  struct Local;
  void Compute(const AeroSection& s, const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t,
               const RotorState* rotor, bool derivatives, Local* out) const;

  AeroModel model_;
  std::vector<int> elastic_offset_;
  std::vector<AeroSection> sections_;
  // Consecutive sections on the same slots (a beam element's or a body's Gauss points): their
  // Newton-matrix blocks are summed before they go to the sink; `mask` marks the slot pairs any
  // of them touches (slots × slots, row-major), the same for the pattern.
  struct Group {
    int first = 0, last = 0;  // sections [first, last)
    std::vector<char> mask;
  };
  std::vector<Group> groups_;
  std::vector<std::vector<int>> rotor_sections_;
};

}  // namespace cosim::smooth
