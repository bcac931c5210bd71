// Blade aerodynamics (smooth_solver/aero): the polars, the C81 reader, exact Newton matrices of
// the strip loads, and the checks of docs/reference/aero.md — hover thrust against blade-element
// momentum theory, a flapping blade's aerodynamic damping and coning, a still rotor in a
// crosswind, and the Pitt–Peters inflow's response.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>

#include "interface/base/errors.h"
#include "smooth_solver/aero/air_loads.h"
#include "smooth_solver/aero/airfoil.h"
#include "smooth_solver/elastic/elastic_model.h"
#include "smooth_solver/model/multibody_model.h"
#include "smooth_solver/model/multibody_system.h"
#include "smooth_solver/simulation/modal_simulation.h"
#include "smooth_solver/simulation/multibody_simulation.h"
#include "tests/interface/message_of.h"

namespace cosim::smooth {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;

class DenseCollector : public SparseSink {
 public:
  explicit DenseCollector(int n) : m(Eigen::MatrixXd::Zero(n, n)) {}
  void Add(int row, int column, double value) override { m(row, column) += value; }
  Eigen::MatrixXd m;
};

// An "ideal" airfoil: C_l = a α over the whole range, no drag, no moment (the assumptions of the
// closed-form blade-element momentum theory). Linear, so a C81 table of it is exact.
class IdealAirfoil : public Airfoil {
 public:
  PolarValue Evaluate(double alpha, double) const override {
    PolarValue p;
    p.cl = 5.73 * WrapAngle(alpha);
    p.cl_alpha = 5.73;
    return p;
  }
  const std::string& name() const override { return name_; }

 private:
  std::string name_ = "ideal";
};

std::string WriteFile(const std::string& name, const std::string& text) {
  // One file per test process: ctest runs the tests of this file in parallel processes, and a
  // table rewritten by one while another reads it failed ("the table ends before the header line").
  const std::string path = ::testing::TempDir() + std::to_string(::getpid()) + "_" + name;
  std::ofstream(path) << text;
  return path;
}

std::string IdealTable() {
  return WriteFile("ideal.c81", WriteC81(IdealAirfoil(), "IDEAL", {-180, -90, 0, 90, 180}, {0.0}));
}

TEST(Airfoil, BuiltinNaca0012MatchesTheFitAndThePostStallFigures) {
  // puma.md: attached C_l = 5.7296 α/√(1 − M²), C_d = 0.006 + 0.13131 α²; C_l ≈ ±1.18 near
  // ±45°, C_d ≈ 2.0 at 90°, C_l = 0 and C_d ≈ 0.02 at 180°; odd C_l and C_m, even C_d.
  const BuiltinNaca0012 f;
  const PolarValue p = f.Evaluate(5 * kDeg, 0.3);
  EXPECT_NEAR(p.cl, 5.7296 * 5 * kDeg / std::sqrt(1 - 0.09), 1e-12);
  EXPECT_NEAR(p.cd, 0.006 + 0.13131 * std::pow(5 * kDeg, 2), 1e-12);
  EXPECT_EQ(p.cm, 0.0);
  EXPECT_NEAR(f.Evaluate(45 * kDeg, 0.1).cl, 1.18, 1e-9);
  EXPECT_NEAR(f.Evaluate(90 * kDeg, 0.1).cd, 2.0, 1e-9);
  EXPECT_NEAR(f.Evaluate(kPi, 0.1).cl, 0.0, 1e-9);
  EXPECT_NEAR(f.Evaluate(kPi, 0.1).cd, 0.02, 1e-9);
  EXPECT_NEAR(f.Evaluate(13 * kDeg, 0.0).cl, 1.30, 0.01);  // C_l,max ≈ 1.33 at 13°
  for (double a : {0.1, 0.5, 2.0, 3.0}) {
    const PolarValue pos = f.Evaluate(a, 0.2), neg = f.Evaluate(-a, 0.2);
    EXPECT_DOUBLE_EQ(pos.cl, -neg.cl);
    EXPECT_DOUBLE_EQ(pos.cd, neg.cd);
    EXPECT_DOUBLE_EQ(pos.cm, -neg.cm);
  }
  // Derivatives against central differences, over the whole range and through the stall blend.
  for (double a = -3.1; a < 3.1; a += 0.0731) {
    for (double m : {0.0, 0.3, 0.6}) {
      const double d = 1e-6;
      const PolarValue p0 = f.Evaluate(a, m), pa = f.Evaluate(a + d, m), pb = f.Evaluate(a - d, m);
      const PolarValue pm = f.Evaluate(a, m + d), pn = f.Evaluate(a, std::max(m - d, 0.0));
      const double dm = m > 0 ? 2 * d : d;
      EXPECT_NEAR(p0.cl_alpha, (pa.cl - pb.cl) / (2 * d), 1e-5) << a << " " << m;
      EXPECT_NEAR(p0.cd_alpha, (pa.cd - pb.cd) / (2 * d), 1e-5) << a << " " << m;
      EXPECT_NEAR(p0.cm_alpha, (pa.cm - pb.cm) / (2 * d), 1e-5) << a << " " << m;
      EXPECT_NEAR(p0.cl_mach, (pm.cl - pn.cl) / dm, 1e-4) << a << " " << m;
      EXPECT_NEAR(p0.cd_mach, (pm.cd - pn.cd) / dm, 1e-4) << a << " " << m;
    }
  }
}

TEST(Airfoil, BuiltinLiftSlopeMovesTheAttachedRangeOnly) {
  // builtin_lift_slope (another deck's attached-flow slope, e.g. MBDyn's C81 NACA 0012 at 6.04):
  // C_l = a α/√(1 − M²) below the stall with the given a, the post-stall plate the fit's own.
  const BuiltinNaca0012 fit, steeper("naca0012_604", 6.04);
  const PolarValue p = steeper.Evaluate(5 * kDeg, 0.3);
  EXPECT_NEAR(p.cl, 6.04 * 5 * kDeg / std::sqrt(1 - 0.09), 1e-12);
  EXPECT_NEAR(p.cl_alpha, 6.04 / std::sqrt(1 - 0.09), 1e-12);
  EXPECT_DOUBLE_EQ(p.cd, fit.Evaluate(5 * kDeg, 0.3).cd);
  for (double a : {60 * kDeg, 120 * kDeg, 179 * kDeg}) {
    EXPECT_DOUBLE_EQ(steeper.Evaluate(a, 0.1).cl, fit.Evaluate(a, 0.1).cl) << a;
    EXPECT_DOUBLE_EQ(steeper.Evaluate(a, 0.1).cd, fit.Evaluate(a, 0.1).cd) << a;
  }
  EXPECT_EQ(steeper.name(), "naca0012_604");
}

TEST(Airfoil, C81TableReadsBackWhatWasWrittenAndInterpolatesBilinearly) {
  const BuiltinNaca0012 f;
  std::vector<double> alpha;
  for (double a = -180; a <= 180; a += 5) alpha.push_back(a);  // 73 rows: C81 counts have 2 columns
  const std::vector<double> mach = {0.0, 0.2, 0.4, 0.5, 0.6, 0.7, 0.75, 0.8, 0.85, 0.9};  // 10: a continuation line
  const std::string text = WriteC81(f, "NACA 0012 (built-in sampled)", alpha, mach);
  const auto table = C81Airfoil::Parse(text, "test.c81", "t");
  EXPECT_EQ(table->title().substr(0, 9), "NACA 0012");
  // At the grid: the written values (4 decimals).
  for (double a : {-180.0, -45.0, 0.0, 5.0, 15.0, 90.0, 180.0}) {
    for (double m : {0.0, 0.4, 0.85, 0.9}) {
      const PolarValue t = table->Evaluate(a * kDeg, m), b = f.Evaluate(a * kDeg, m);
      EXPECT_NEAR(t.cl, b.cl, 6e-5) << a << " " << m;
      EXPECT_NEAR(t.cd, b.cd, 6e-5) << a << " " << m;
      EXPECT_NEAR(t.cm, b.cm, 6e-5) << a << " " << m;
    }
  }
  // Between grid points: bilinear, with the slope of the interval.
  const PolarValue lo = table->Evaluate(5 * kDeg, 0.2), hi = table->Evaluate(10 * kDeg, 0.2);
  const PolarValue mid = table->Evaluate(7.5 * kDeg, 0.2);
  EXPECT_NEAR(mid.cl, 0.5 * (lo.cl + hi.cl), 1e-12);
  EXPECT_NEAR(mid.cl_alpha, (hi.cl - lo.cl) / (5 * kDeg), 1e-9);
  const PolarValue m1 = table->Evaluate(5 * kDeg, 0.45);
  EXPECT_NEAR(m1.cl, 0.5 * (table->Evaluate(5 * kDeg, 0.4).cl + table->Evaluate(5 * kDeg, 0.5).cl), 1e-12);
  // Beyond the Mach range: constant.
  EXPECT_EQ(table->Evaluate(5 * kDeg, 0.95).cl, table->Evaluate(5 * kDeg, 0.9).cl);
  EXPECT_EQ(table->Evaluate(5 * kDeg, 0.95).cl_mach, 0.0);
}

TEST(Airfoil, MalformedC81TablesAreRejectedWithTheLine) {
  const std::string good = WriteC81(BuiltinNaca0012(), "T", {-180, 0, 180}, {0.0, 0.5});
  auto expect_error = [](const std::string& text, const std::string& fragment) {
    try {
      C81Airfoil::Parse(text, "bad.c81", "x");
      ADD_FAILURE() << "accepted: " << fragment;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
  };
  std::string t = good;
  t.replace(30, 2, " 0");  // ML = 0
  expect_error(t, "bad.c81:1: ML (lift Mach count)");
  t = good;
  t.replace(32, 2, " x");
  expect_error(t, "NL (lift alpha count)");
  // α not increasing (the second row of the lift table is line 4).
  t = good;
  const size_t row2 = t.find("\n", t.find("\n", t.find("\n") + 1) + 1) + 1;
  t.replace(row2, 7, "-190.00");
  expect_error(t, "bad.c81:4: lift angle of attack -190 deg does not increase");
  // A range that does not reach ±180°.
  expect_error(WriteC81(BuiltinNaca0012(), "T", {-20, 0, 20}, {0.0}), "must cover -180");
  // Not a number; truncated; trailing text.
  t = good;
  t.replace(row2 + 7, 7, "  1.2.3");
  expect_error(t, "hold '1.2.3'; expected a number");
  expect_error(good.substr(0, good.size() / 2), "the table ends before");
  expect_error(good + "  extra\n", "text after the moment table");
}

// A rigid hub spinning at Ω about z carrying `blades` straight blades as aero surfaces on the
// hub itself (a rigid rotor), radius R = 7.49 m, chord 0.537 m: the research Puma's σ = 0.09129.
std::string RigidRotor(const std::string& airfoil_block, const std::string& airfoil, double theta75, double twist,
                       double omega, const std::string& inflow, const std::string& extra_air = "",
                       bool clockwise = false, int blades = 4) {
  const double R = 7.49;
  std::string s =
      "model { bodies { name: \"hub\" mass: 100 inertia: [10, 10, 20] angular_velocity: [0, 0, " +
      std::to_string(omega) +
      "] }\n"
      "joints { name: \"shaft\" type: REVOLUTE body1: \"ground\" body2: \"hub\" point: [0, 0, 0] axis: [0, 0, 1] "
      "drive { quantity: ANGULAR_SPEED function { constant: " +
      std::to_string(omega) +
      " } } }\n"
      "air { speed_of_sound: 1e9 " +
      airfoil_block + extra_air + "\n";
  std::string names;
  for (int k = 0; k < blades; ++k) {
    const double psi = 2 * kPi * k / blades;
    const double ax = std::cos(psi), ay = std::sin(psi);
    // Leading edge in the direction of motion.
    const double sign = clockwise ? -1.0 : 1.0;
    const double cx = -ay * sign, cy = ax * sign;
    char buf[1024];
    std::snprintf(
        buf, sizeof buf,
        "surfaces { name: \"b%d\" body: \"hub\" root: [0, 0, 0] axis: [%.17g, %.17g, 0] chord: [%.17g, %.17g, 0] "
        "upper: [0, 0, 1] segments: 20 gauss_points: 4 "
        "stations { s: 0 chord: 0.537 twist: %.17g airfoil: \"%s\" } "
        "stations { s: %.17g chord: 0.537 twist: %.17g airfoil: \"%s\" } }\n",
        k + 1, ax, ay, cx, cy, theta75 - 0.75 * twist, airfoil.c_str(), R, theta75 + 0.25 * twist, airfoil.c_str());
    s += buf;
    names += "\"b" + std::to_string(k + 1) + "\"" + (k + 1 < blades ? ", " : "");
  }
  if (!inflow.empty()) {
    s += "rotors { name: \"main\" hub: \"hub\" axis: [0, 0, 1] radius: 7.49 inflow: " + inflow + " surfaces: [" +
         names + "] }\n";
  }
  s += "} } numerics { end_time: 1 step: 1e-3 }";
  return s;
}

MultibodySystem Build(const std::string& text, const std::vector<std::string>& sets = {}) {
  return BuildMultibodySystem(BuildMultibodyModel(interface::ScenarioFile::Parse(text, "aero.pbtxt", sets)));
}

// K = −∂f/∂q and C = −∂f/∂q̇ of the air loads against central differences of f, at q0 moved
// off the manifold by ±dq and velocities ±v (deterministic patterns), time t: the relative
// errors of each (Frobenius norms).
std::pair<double, double> TangentErrors(const AirLoads& air, const SystemData& data, const Eigen::VectorXd& q0,
                                        double dq, double v, double t) {
  const int n = static_cast<int>(q0.size());
  Eigen::VectorXd q = q0, qdot(n);
  for (int i = 0; i < n; ++i) {
    q(i) += dq * std::sin(0.7 * i + 0.2);
    qdot(i) = v * std::cos(1.3 * i);
  }
  DenseCollector K(n), C(n);
  air.AddTangent(q, qdot, t, data, 1.0, 0.0, &K);
  air.AddTangent(q, qdot, t, data, 0.0, 1.0, &C);
  auto force = [&](const Eigen::VectorXd& qq, const Eigen::VectorXd& vv) {
    Eigen::VectorXd f = Eigen::VectorXd::Zero(n);
    air.AddForce(qq, vv, t, data, f);
    return f;
  };
  Eigen::MatrixXd Kfd(n, n), Cfd(n, n);
  const double d = 1e-6;
  for (int j = 0; j < n; ++j) {
    Eigen::VectorXd qp = q, qm = q, vp = qdot, vm = qdot;
    qp(j) += d;
    qm(j) -= d;
    vp(j) += d;
    vm(j) -= d;
    Kfd.col(j) = -(force(qp, qdot) - force(qm, qdot)) / (2 * d);
    Cfd.col(j) = -(force(q, vp) - force(q, vm)) / (2 * d);
  }
  EXPECT_GT(Kfd.norm(), 1.0);
  EXPECT_GT(Cfd.norm(), 1.0);
  return {(K.m - Kfd).norm() / Kfd.norm(), (C.m - Cfd).norm() / Cfd.norm()};
}

TEST(AirLoads, TangentsMatchFiniteDifferences) {
  // Off the manifold (perturbed frames) and in a wind, on a rigid wing and on a twisted beam:
  // every term of K = −∂f/∂q and C = −∂f/∂q̇ (no rotor: the air velocity does not depend on q).
  const std::string beam_station = "ea: 1e6 gj: 1e3 ei_flap: 1e3 ei_lag: 1e4 mass: 2 inertia_torsion: 1e-3";
  const std::string text =
      "model { bodies { name: \"wing\" mass: 1 inertia: [1, 1, 1] rotation: [0.1, -0.2, 0.3] }\n"
      "beams { name: \"blade\" root: [0, 0, 1] axis: [1, 0, 0] chord: [0, -1, 0] elements: 2 nodes_per_element: 3 "
      "root_body: \"ground\" stations { s: 0 " +
      beam_station + " twist: 0.1 } stations { s: 3 " + beam_station +
      " twist: -0.1 } }\n"
      "air { wind_x { constant: 3 } wind_y { constant: -40 } wind_z { constant: 5 }\n"
      "surfaces { name: \"w\" body: \"wing\" root: [0, 0, 0] axis: [0, 1, 0] chord: [1, 0, 0] upper: [0, 0, 1] "
      "segments: 3 stations { s: 0 chord: 0.5 twist: 0.1 airfoil: \"naca0012\" quarter_chord: 0.02 } "
      "stations { s: 2 chord: 0.3 twist: -0.2 airfoil: \"naca0012\" } }\n"
      "surfaces { name: \"b\" beam: \"blade\" upper: [0, 0, -1] gauss_points: 3 "
      "stations { s: 0.5 chord: 0.4 twist: 0.05 airfoil: \"naca0012\" quarter_chord: -0.01 } "
      "stations { s: 3 chord: 0.3 airfoil: \"naca0012\" } } } }\n"
      "numerics { end_time: 1 step: 1e-3 }";
  const MultibodySystem sys = Build(text);
  SystemData data = MakeData(sys);
  ASSERT_NE(sys.air_loads, nullptr);
  const AirLoads& air = *sys.air_loads;
  const int n = sys.coordinates;
  const auto [k_error, c_error] = TangentErrors(air, data, sys.q0, 0.05, 8.0, 0.3);
  EXPECT_LT(k_error, 1e-6);
  EXPECT_LT(c_error, 1e-6);
  DenseCollector K(n), C(n);
  air.AddTangent(sys.q0, Eigen::VectorXd::Constant(n, 3.0), 0.3, data, 1.0, 0.0, &K);
  air.AddTangent(sys.q0, Eigen::VectorXd::Constant(n, 3.0), 0.3, data, 0.0, 1.0, &C);
  // And the pattern covers every entry the tangent touches.
  struct Marker : SparseSink {
    explicit Marker(int n) : m(Eigen::MatrixXi::Zero(n, n)) {}
    void Add(int r, int c, double) override { m(r, c) = 1; }
    Eigen::MatrixXi m;
  } pattern(n);
  air.Pattern(&pattern);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      if (K.m(i, j) != 0.0 || C.m(i, j) != 0.0) {
        EXPECT_EQ(pattern.m(i, j), 1) << i << "," << j;
      }
    }
  }
}

TEST(AirLoads, Hex27ReferenceLineCarriesTheSameLoadsAsARigidWingAndExactTangents) {
  // The same straight wing as a rigid body and as a hex27 mesh: undeformed at rest in a wind,
  // the mesh's sections (points interpolated from 27 nodes, frame from the deformation
  // gradient) carry the rigid wing's loads; deformed, the tangent is exact.
  const std::string stations =
      "stations { s: 0.1 chord: 0.3 twist: 0.08 airfoil: \"naca0012\" quarter_chord: 0.01 } "
      "stations { s: 1.9 chord: 0.25 twist: -0.05 airfoil: \"naca0012\" }";
  const std::string text =
      "model { bodies { name: \"wing\" mass: 1 inertia: [1, 1, 1] position: [1, 0, 0] }\n"
      "elastic_bodies { name: \"flex\" material { density: 2700 young: 7e10 poisson: 0.33 } "
      "beam { length: 2 chord: 0.3 thickness: 0.05 elements_along: 3 root: [0, 0, 0] } }\n"
      "air { wind_x { constant: -2 } wind_y { constant: -30 } wind_z { constant: 1 }\n"
      "surfaces { name: \"rigid\" body: \"wing\" root: [0, 0, 0] axis: [1, 0, 0] chord: [0, 1, 0] upper: [0, 0, 1] "
      "segments: 3 " +
      stations +
      " }\n"
      "surfaces { name: \"elastic\" elastic_body: \"flex\" root: [0, 0, 0] axis: [1, 0, 0] chord: [0, 1, 0] "
      "upper: [0, 0, 1] segments: 3 " +
      stations +
      " } } }\n"
      "numerics { end_time: 1 step: 1e-3 }";
  const interface::ScenarioFile file = interface::ScenarioFile::Parse(text, "aero.pbtxt", {});
  const MultibodyModel model = BuildMultibodyModel(file);
  std::vector<ElasticBodySpec> elastic =
      BuildElasticBodies(interface::Checks(file), file.proto().model(), model.BodyNames());
  const MultibodySystem sys = BuildMultibodySystem(model, &elastic);
  SystemData data = MakeData(sys);
  const AirLoads& air = *sys.air_loads;
  const int n = sys.coordinates;
  const Eigen::VectorXd qdot0 = Eigen::VectorXd::Zero(n);
  Eigen::VectorXd f = Eigen::VectorXd::Zero(n);
  air.AddForce(sys.q0, qdot0, 0.0, data, f);
  const Eigen::Vector3d rigid = f.head<3>();
  Eigen::Vector3d flexible = Eigen::Vector3d::Zero();
  for (int k = sys.elastic_offset[0]; k < n; k += 3) flexible += f.segment<3>(k);
  std::printf("wing in a 30 m/s wind: rigid (%.4f, %.4f, %.4f) N, hex27 (%.4f, %.4f, %.4f) N\n", rigid.x(), rigid.y(),
              rigid.z(), flexible.x(), flexible.y(), flexible.z());
  EXPECT_GT(rigid.norm(), 50.0);
  EXPECT_LT((rigid - flexible).norm(), 1e-9 * rigid.norm());
  // Deformed and moving: K and C against central differences.
  const auto [k_error, c_error] = TangentErrors(air, data, sys.q0, 0.01, 3.0, 0.0);
  EXPECT_LT(k_error, 1e-6);
  EXPECT_LT(c_error, 1e-6);
}

// Thrust of N blades of the rigid rotor in hover under a uniform induced velocity ν, by
// an independent quadrature of the same strip theory (no small angles): per span
// dT = ½ ρ c a (θ − φ) (U_T² + ν²) cos φ with U_T = Ω r, φ = atan(ν/U_T), no drag.
double StripThrust(double nu, double omega, double theta75, double twist) {
  const double R = 7.49, c = 0.537, rho = 1.225, a = 5.73;
  const int n = 20000;
  double T = 0.0;
  for (int i = 0; i < n; ++i) {
    const double r = (i + 0.5) * R / n;
    const double ut = omega * r, phi = std::atan2(nu, ut);
    const double theta = theta75 + twist * (r / R - 0.75);
    T += 0.5 * rho * c * a * (theta - phi) * (ut * ut + nu * nu) * std::cos(phi) * R / n;
  }
  return 4 * T;
}

TEST(AirLoads, HoverThrustMatchesBladeElementMomentumTheory) {
  // docs/reference/aero.md: the ideal rotor (constant chord, linear twist, no cut-out, no tip loss,
  // constant lift slope, uniform inflow) gives C_T = 0.002755 at θ75 = 5° and 0.007310 at 10°.
  // The strip loads make their own thrust; the rotor solves Glauert's 2 ρ A ν² = T. Against an
  // independent quadrature of the exact strip theory: quadrature error; against the closed
  // form: the small-angle approximations it makes (U ≈ U_T, cos φ ≈ 1).
  const std::string table = IdealTable();
  const double omega = 28.0, R = 7.49, A = kPi * R * R, rho = 1.225;
  for (const auto& [theta_deg, ct_closed] : std::vector<std::pair<double, double>>{{5.0, 0.002755}, {10.0, 0.007310}}) {
    const double theta = theta_deg * kDeg, twist = -8 * kDeg;
    MultibodySystem sys = Build(RigidRotor("airfoils { name: \"ideal\" c81_file: \"" + table + "\" }", "ideal", theta,
                                           twist, omega, "UNIFORM"));
    SystemData data = MakeData(sys);
    sys.AcceptStep(sys.q0, sys.qdot0, 0.0, &data);
    const AirLoads::RotorResult r = sys.air_loads->Rotor(0, sys.q0, sys.qdot0, 0.0, data);
    const double ct = r.thrust / (rho * A * std::pow(omega * R, 2));
    // Independent: ν from 2 ρ A ν² = T_strip(ν) by bisection.
    double lo = 0.0, hi = 50.0;
    for (int it = 0; it < 200; ++it) {
      const double mid = 0.5 * (lo + hi);
      (2 * rho * A * mid * mid - StripThrust(mid, omega, theta, twist) > 0 ? hi : lo) = mid;
    }
    const double ct_strip = StripThrust(lo, omega, theta, twist) / (rho * A * std::pow(omega * R, 2));
    std::printf(
        "hover θ75 = %.0f°: C_T %.6f (T = %.1f N, ν = %.4f m/s, λ = %.5f); strip quadrature %.6f "
        "(%.1e); closed form %.6f (%.2f %%)\n",
        theta_deg, ct, r.thrust, r.induced, r.inflow_ratio, ct_strip, std::abs(ct / ct_strip - 1), ct_closed,
        100 * (ct / ct_closed - 1));
    // The table holds C_l to 4 decimals (a π/2 = 9.00066 is 9.0007): 4e-6 of the lift.
    EXPECT_NEAR(ct / ct_strip, 1.0, 1e-5);
    EXPECT_NEAR(r.induced / lo, 1.0, 1e-5);
    EXPECT_NEAR(ct / ct_closed, 1.0, 0.01);
    EXPECT_NEAR(r.inflow_ratio, std::sqrt(ct / 2), 1e-6);  // hover: λ = √(C_T/2)
  }
}

TEST(AirLoads, HoverInflowCarriesItsInducedPowerFactor) {
  // induced_velocity_factor κ: the blades see ν = κ ν_m where 2 ρ A ν_m² = T(κ ν_m) in hover
  // (MBDyn's hover correction K_H acts so with κ = K_H²). Against an independent bisection of
  // that balance with the strip quadrature: the secant's and the table's tolerance. More inflow
  // lowers the angle of attack: the thrust falls below the plain momentum balance's.
  const std::string table = IdealTable();
  const double omega = 28.0, R = 7.49, A = kPi * R * R, rho = 1.225, theta = 8 * kDeg, twist = -8 * kDeg;
  const std::string air = "airfoils { name: \"ideal\" c81_file: \"" + table + "\" }";
  auto hover = [&](double kappa) {
    MultibodySystem sys = Build(RigidRotor(air, "ideal", theta, twist, omega, "UNIFORM"),
                                {"model.air.rotors[0].induced_velocity_factor=" + std::to_string(kappa)});
    SystemData data = MakeData(sys);
    sys.AcceptStep(sys.q0, sys.qdot0, 0.0, &data);
    return sys.air_loads->Rotor(0, sys.q0, sys.qdot0, 0.0, data);
  };
  const AirLoads::RotorResult plain = hover(1.0), corrected = hover(1.21);
  double lo = 0.0, hi = 50.0;
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    (2 * rho * A * mid * mid - StripThrust(1.21 * mid, omega, theta, twist) > 0 ? hi : lo) = mid;
  }
  const double nu_m = lo, thrust = StripThrust(1.21 * nu_m, omega, theta, twist);
  std::printf(
      "hover θ75 = 8°: κ = 1 ν = %.4f m/s, T = %.1f N; κ = 1.21 ν = %.4f m/s (independent %.4f = 1.21 × %.4f), "
      "T = %.1f N (independent %.1f)\n",
      plain.induced, plain.thrust, corrected.induced, 1.21 * nu_m, nu_m, corrected.thrust, thrust);
  EXPECT_NEAR(corrected.induced / (1.21 * nu_m), 1.0, 1e-5);
  EXPECT_NEAR(corrected.thrust / thrust, 1.0, 1e-5);
  EXPECT_LT(corrected.thrust, 0.97 * plain.thrust);
  EXPECT_GT(corrected.induced, 1.1 * plain.induced);
}

TEST(AirLoads, BuiltinLiftSlopeScalesTheThrustWithoutInflow) {
  // Hover without inflow at 4° (attached flow everywhere, incompressible): the sections' lift is
  // a α, so the rotor's thrust scales with the slope given; the in-plane drag adds no thrust.
  const double omega = 28.0, theta = 4 * kDeg, twist = 0.0;
  auto thrust = [&](const std::string& air, const std::string& airfoil) {
    MultibodySystem sys = Build(RigidRotor(air, airfoil, theta, twist, omega, "NONE"));
    SystemData data = MakeData(sys);
    sys.AcceptStep(sys.q0, sys.qdot0, 0.0, &data);
    return sys.air_loads->Rotor(0, sys.q0, sys.qdot0, 0.0, data).thrust;
  };
  const double fit = thrust("", "naca0012"),
               steeper = thrust("airfoils { name: \"deck\" builtin_lift_slope: 6.04 }", "deck");
  std::printf("thrust without inflow: fit (5.7296/rad) %.2f N, slope 6.04/rad %.2f N, ratio %.6f\n", fit, steeper,
              steeper / fit);
  EXPECT_GT(fit, 1000.0);
  EXPECT_NEAR(steeper / fit, 6.04 / 5.7296, 1e-9);
}

TEST(AirLoads, OneModelledBladeOfAFourBladeRotorSeesTheWholeRotorsInflow) {
  // `blades: 4` on a rotor that models one blade: in hover every blade carries the same load, so
  // the inflow must be the four-blade rotor's (to the secant's tolerance) and the thrust reported
  // a quarter of it (the modelled blade's). Without `blades` the one blade would see the inflow
  // of a one-blade rotor: lower, so its thrust is higher than a quarter.
  const double theta = 8 * kDeg, twist = -8 * kDeg, omega = 28.0;
  const std::string air = "airfoils { name: \"ideal\" c81_file: \"" + IdealTable() + "\" }";
  auto hover = [&](int modelled, const std::vector<std::string>& sets) {
    MultibodySystem sys = Build(RigidRotor(air, "ideal", theta, twist, omega, "UNIFORM", "", false, modelled), sets);
    SystemData data = MakeData(sys);
    sys.AcceptStep(sys.q0, sys.qdot0, 0.0, &data);
    return sys.air_loads->Rotor(0, sys.q0, sys.qdot0, 0.0, data);
  };
  const AirLoads::RotorResult four = hover(4, {}), one_of_four = hover(1, {"model.air.rotors[0].blades=4"}),
                              alone = hover(1, {});
  std::printf(
      "hover: four blades ν = %.6f m/s, T = %.1f N; one modelled of four ν = %.6f, T = %.1f N; "
      "a one-blade rotor ν = %.6f, T = %.1f N\n",
      four.induced, four.thrust, one_of_four.induced, one_of_four.thrust, alone.induced, alone.thrust);
  EXPECT_NEAR(one_of_four.induced / four.induced, 1.0, 1e-8);
  EXPECT_NEAR(one_of_four.thrust / (0.25 * four.thrust), 1.0, 1e-8);
  EXPECT_LT(alone.induced, 0.7 * four.induced);
  EXPECT_GT(alone.thrust, 0.25 * four.thrust * 1.05);
  // Fewer blades than the surfaces listed: refused, naming the field.
  try {
    (void)Build(RigidRotor(air, "ideal", theta, twist, omega, "UNIFORM", "", false, 2),
                {"model.air.rotors[0].blades=1"});
    ADD_FAILURE() << "blades < surfaces accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("model.air.rotors[0].blades"), std::string::npos) << e.what();
  }
}

TEST(AirLoads, StillRotorInACrosswindLiftsTheBladeFacingIt) {
  // docs/reference/aero.md, puma.md: hub still, collective 10°, air along +y, blade 1 along +x with
  // its leading edge towards −y (a clockwise rotor): blade 1 sees the wind on its leading edge
  // at +10° and lifts; blade 3 (along −x) sees it from its trailing edge (α ≈ −170°) and is
  // pushed down; blades 2 and 4 see it along their span and feel almost nothing. The induced
  // velocity is held at zero (still rotor).
  MultibodySystem sys =
      Build(RigidRotor("", "naca0012", 10 * kDeg, 0.0, 0.0, "UNIFORM", "wind_y { constant: 25 }", true));
  SystemData data = MakeData(sys);
  const Eigen::VectorXd qdot = Eigen::VectorXd::Zero(sys.coordinates);
  sys.AcceptStep(sys.q0, qdot, 0.0, &data);
  const AirLoads& air = *sys.air_loads;
  double lift[4], alpha[4];
  for (int b = 0; b < 4; ++b) {
    const AirLoads::SectionResult s = air.Evaluate(air.Section(b, 5.0, 1.0), sys.q0, qdot, 0.0, data);
    lift[b] = s.force.z();
    alpha[b] = s.alpha / kDeg;
  }
  std::printf(
      "crosswind 25 m/s at r = 5 m: normal force per span %.1f, %.2f, %.1f, %.2f N/m; α %.1f, %.1f, %.1f, %.1f deg\n",
      lift[0], lift[1], lift[2], lift[3], alpha[0], alpha[1], alpha[2], alpha[3]);
  EXPECT_NEAR(alpha[0], 10.0, 1e-9);
  EXPECT_NEAR(alpha[2], -170.0, 1e-9);
  const double q = 0.5 * 1.225 * 0.537 * 25 * 25;
  EXPECT_GT(lift[0], 0.5 * q);  // C_l(10°) ≈ 1.0
  EXPECT_LT(lift[2], -0.2 * q);
  EXPECT_LT(std::abs(lift[1]), 0.01 * lift[0]);
  EXPECT_LT(std::abs(lift[3]), 0.01 * lift[0]);
  const AirLoads::RotorResult r = air.Rotor(0, sys.q0, qdot, 0.0, data);
  EXPECT_EQ(r.induced, 0.0);
}

TEST(AirLoads, StillRotorInAGustFrontLiftsBladeOneAndPressesBladeThree) {
  // scenarios/aero/still_rotor_gust.pbtxt: rigid blades on Hunt–Crossley flap stops settle on
  // their droop stops, then a 25 m/s 1 − cos gust front crosses the still rotor along +y. Blade 1
  // (the wind on its leading edge) lifts off its stop, blade 3 (reverse flow) is pressed into
  // it, blades 2 and 4 (wind along their span) stay put.
  MultibodySimulation sim(
      interface::ScenarioFile::Load(std::string(COSIM_SOURCE_DIR) + "/scenarios/aero/still_rotor_gust.pbtxt", {}));
  // The blades start flat and are still bouncing on their stops when the gust arrives (t = 2 s):
  // measured against blade 2, which moves with them but feels no gust.
  const double h = 1e-3;
  std::vector<double> v(9);
  double up1 = 0, down3 = 0, off4 = 0, rest = 0;
  for (int k = 0; k < 6500; ++k) {
    sim.Step(k * h, h);
    sim.Probe(&v);
    up1 = std::max(up1, v[0] - v[1]);
    down3 = std::min(down3, v[2] - v[1]);
    off4 = std::max(off4, std::abs(v[3] - v[1]));
    rest = v[1];
  }
  std::printf(
      "gust: blade 2 at %.3f° (droop stop −10°); against it blade 1 up to %+.3f°, blade 3 down to %+.4f°, "
      "blade 4 within %.5f°\n",
      rest / kDeg, up1 / kDeg, down3 / kDeg, off4 / kDeg);
  EXPECT_NEAR(rest / kDeg, -10.2, 0.2);  // on the droop stop, a little into it
  EXPECT_GT(up1, 2 * kDeg);
  EXPECT_LT(down3, -0.03 * kDeg);
  EXPECT_LT(off4, 0.5 * std::abs(down3));  // measured 0.036° against 0.092°: their bounce is not quite in step
}

TEST(AirLoads, GustFrontTravelsWithItsProfile) {
  // A 1 − cos pulse 100 m long, peak 25 m/s along +y, front moving along +y at 20 m/s: a point
  // at y = 40 m sees the front after 2 s and the peak after 4.5 s (distance travelled 50 m).
  AirModel air;
  GustFront g;
  g.front_direction = Eigen::Vector3d::UnitY();
  g.direction = Eigen::Vector3d::UnitY();
  g.front_speed = 20.0;
  scenario::TimeFunction pulse;
  pulse.mutable_cosine_pulse()->set_peak(25.0);
  pulse.mutable_cosine_pulse()->set_duration(100.0);
  const interface::ScenarioFile file = interface::ScenarioFile::Parse("", "g.pbtxt", {});
  g.profile = interface::TimeFunction::Build(interface::Checks(file), "profile", pulse);
  air.gusts.push_back(g);
  const Eigen::Vector3d x(3.0, 40.0, 1.0);
  EXPECT_EQ(air.Velocity(x, 1.9).norm(), 0.0);
  EXPECT_NEAR(air.Velocity(x, 4.5).y(), 25.0, 1e-12);
  EXPECT_NEAR(air.Velocity(x, 3.25).y(), 12.5, 1e-12);
  EXPECT_EQ(air.Velocity(x, 7.1).norm(), 0.0);
}

// The air of a scene that holds only an airwake (`fields` inside model.air.airwake).
AirModel AirOf(const std::string& fields, const std::vector<std::string>& sets = {}) {
  return BuildMultibodyModel(
             interface::ScenarioFile::Parse("model { air { airwake { " + fields + " } } }", "airwake.pbtxt", sets))
      .aero.air;
}

TEST(AirLoads, AirwakeFormsScaleWithTheWindAndFollowTheRelativeDirection) {
  // Ship axes x bow, y port, z up; ψ where the wind comes from, clockwise from the bow seen from
  // above. A head wind (ψ = 0) blows aft, −x; one from starboard (ψ = 90°, starboard is −y)
  // blows to port, +y; one from port (270°) to starboard. Every vertical form is k V.
  const double V = 20.0, tol = 1e-12;
  AirModel air = AirOf("speed: 20 direction: 0 form: UNIFORM windward: 0.25");
  EXPECT_LT((air.Velocity(Eigen::Vector3d(3, -2, 1), 0.0) - Eigen::Vector3d(-V, 0, 0.25 * V)).norm(), tol);
  air = AirOf("speed: 20 direction: 90 form: UNIFORM windward: 0.25");
  EXPECT_LT((air.Velocity(Eigen::Vector3d::Zero(), 0.0) - Eigen::Vector3d(0, V, 0.25 * V)).norm(), tol);
  air = AirOf("speed: 20 direction: 270 form: UNIFORM windward: 0.25");
  EXPECT_LT((air.Velocity(Eigen::Vector3d::Zero(), 0.0) - Eigen::Vector3d(0, -V, 0.25 * V)).norm(), tol);
  // A ship heading along +y (bow [0, 1, 0]; port is then −x), hub at (5, 5, 3): a head wind
  // blows along −y; a wind from 45° to starboard blows from ahead and starboard, towards
  // aft and port: V (−cos 45° bow + sin 45° port).
  air = AirOf("speed: 20 direction: 45 form: UNIFORM windward: 0 bow: [0, 1, 0] origin: [5, 5, 3]");
  const double c = std::sqrt(0.5) * V;
  EXPECT_LT((air.Velocity(Eigen::Vector3d::Zero(), 0.0) - Eigen::Vector3d(-c, -c, 0)).norm(), tol);
  // LINEAR: k from windward (+0.3, up-wash) at ξ = −L to leeward (−0.1, down-wash) at +L, held
  // beyond. A head wind blows towards −x, so the windward side is ahead of the origin (x > 0).
  air = AirOf("speed: 20 direction: 0 form: LINEAR windward: 0.3 leeward: -0.1 length: 7.5");
  EXPECT_NEAR(air.Velocity(Eigen::Vector3d(7.5, 1, 0), 0.0).z(), 0.3 * V, tol);
  EXPECT_NEAR(air.Velocity(Eigen::Vector3d(20, 0, 0), 0.0).z(), 0.3 * V, tol);
  EXPECT_NEAR(air.Velocity(Eigen::Vector3d(0, 4, 2), 0.0).z(), 0.1 * V, tol);
  EXPECT_NEAR(air.Velocity(Eigen::Vector3d(-3.75, 0, 0), 0.0).z(), 0.0, tol);
  EXPECT_NEAR(air.Velocity(Eigen::Vector3d(-9, 0, 0), 0.0).z(), -0.1 * V, tol);
  EXPECT_NEAR(air.Velocity(Eigen::Vector3d(-9, 0, 0), 0.0).x(), -V, tol);
  // STEP: windward before the edge (2 m along the wind from the origin), leeward past it, a half
  // cosine over the 1 m blend: halfway at the edge, a quarter of the change 0.5 (1 − cos 60°)
  // a third of the way in. Wind from starboard: ξ = y.
  air = AirOf("speed: 20 direction: 90 form: STEP windward: 0.2 leeward: -0.2 edge: 2 edge_width: 1");
  EXPECT_NEAR(air.Velocity(Eigen::Vector3d(0, 1.5, 0), 0.0).z(), 0.2 * V, tol);
  EXPECT_NEAR(air.Velocity(Eigen::Vector3d(0, 2.0, 0), 0.0).z(), 0.0, tol);
  EXPECT_NEAR(air.Velocity(Eigen::Vector3d(0, 2.5, 0), 0.0).z(), -0.2 * V, tol);
  EXPECT_NEAR(air.Velocity(Eigen::Vector3d(0, 1.5 + 1.0 / 3.0, 0), 0.0).z(), (0.2 - 0.4 * 0.25) * V, 1e-12);
  // Mirror symmetry: the winds from ψ and 360° − ψ are each other's mirror images in the ship's
  // centre plane (y ↦ −y), points and velocities alike.
  const AirModel from_starboard = AirOf("speed: 20 direction: 60 form: LINEAR windward: 0.3 leeward: -0.1 length: 7.5");
  const AirModel from_port = AirOf("speed: 20 direction: 300 form: LINEAR windward: 0.3 leeward: -0.1 length: 7.5");
  const Eigen::Vector3d mirror(1, -1, 1);
  for (const Eigen::Vector3d& x : {Eigen::Vector3d(2, 3, 0), Eigen::Vector3d(-5, 1, 1), Eigen::Vector3d(6, -6, 0)}) {
    const Eigen::Vector3d a = from_starboard.Velocity(x, 0.0), b = from_port.Velocity(x.cwiseProduct(mirror), 0.0);
    EXPECT_LT((a.cwiseProduct(mirror) - b).norm(), tol) << x.transpose();
  }
  // With a ramp_time the whole field grows as ½ (1 − cos(π t / T)) from t = 0: none at the
  // start, half at T/2, all of it from T on.
  air = AirOf("speed: 20 direction: 0 form: UNIFORM windward: 0.25 ramp_time: 4");
  EXPECT_EQ(air.Velocity(Eigen::Vector3d::Zero(), 0.0).norm(), 0.0);
  EXPECT_LT((air.Velocity(Eigen::Vector3d::Zero(), 2.0) - Eigen::Vector3d(-0.5 * V, 0, 0.125 * V)).norm(), tol);
  EXPECT_LT((air.Velocity(Eigen::Vector3d::Zero(), 9.0) - Eigen::Vector3d(-V, 0, 0.25 * V)).norm(), tol);
  // Gusts and the scene's wind add to the airwake.
  air = AirOf("speed: 20 direction: 0 form: UNIFORM windward: 0.25", {"model.air.wind_z.constant=-1"});
  EXPECT_NEAR(air.Velocity(Eigen::Vector3d::Zero(), 0.0).z(), 0.25 * V - 1.0, tol);
}

TEST(AirLoads, AirwakeSurveyIsBilinearOnItsGridInShipAxesAndReadFromCsv) {
  // A 3 × 2 survey (u, v, w)/V in ship axes, the ship heading along +y (port −x), origin at
  // (1, 0, 0): at ship (x_s, y_s) the global point is origin + x_s ŷ − y_s x̂. Bilinear inside a
  // cell, held beyond the grid's edges, scaled by V and turned into global axes.
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("cosim_airwake_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "survey.csv") << "# x_s, y_s: ship axes [m]; u, v, w over V\n"
                                       "x,y,u,v,w\n-5,-4,-1,0,0.1\n-5,4,-1,0.2,0.3\n0,-4,-1,0,0.2\n"
                                       "0,4,-1,0,0\n10,-4,-0.5,0,-0.2\n10,4,-0.5,0,-0.2\n";
  std::ofstream(dir / "wake.pbtxt") << "model { air { airwake { speed: 10 form: TABLE grid_file: \"survey.csv\" "
                                       "bow: [0, 1, 0] origin: [1, 0, 0] } } }";
  const interface::ScenarioFile file = interface::ScenarioFile::Load((dir / "wake.pbtxt").string(), {});
  EXPECT_EQ(file.proto().model().air().airwake().grid_size(), 6);
  const AirModel air = BuildMultibodyModel(file).aero.air;
  auto at = [&](double xs, double ys) { return air.Velocity(Eigen::Vector3d(1.0 - ys, xs, 0.7), 0.0); };
  auto global = [](double u, double v, double w) -> Eigen::Vector3d { return Eigen::Vector3d(-v, u, w) * 10.0; };
  EXPECT_LT((at(-5, 4) - global(-1, 0.2, 0.3)).norm(), 1e-12);
  // Centre of the first cell: the mean of its four corners.
  EXPECT_LT((at(-2.5, 0) - global(-1, 0.05, 0.15)).norm(), 1e-12);
  // Along the edge y = −4 between x = 0 and 10, 30 % of the way: w = 0.2 − 0.3 · 0.4.
  EXPECT_LT((at(3, -4) - global(-0.85, 0, 0.08)).norm(), 1e-12);
  // Beyond the grid: held at its edge.
  EXPECT_LT((at(25, 9) - global(-0.5, 0, -0.2)).norm(), 1e-12);
  EXPECT_LT((at(-25, -9) - global(-1, 0, 0.1)).norm(), 1e-12);
  // A grid that is not rectangular is refused, naming the points it has.
  std::ofstream(dir / "survey.csv") << "x,y,u,v,w\n0,0,1,0,0\n1,0,1,0,0\n0,1,1,0,0\n";
  const std::string m = interface::MessageOf(
      [&] { BuildMultibodyModel(interface::ScenarioFile::Load((dir / "wake.pbtxt").string(), {})); });
  EXPECT_NE(m.find("model.air.airwake.grid: 3 points over 2 distinct x and 2 distinct y"), std::string::npos) << m;
  std::filesystem::remove_all(dir);
}

TEST(AirLoads, BadAirwakeNamesTheFieldAndWhatIsExpected) {
  auto error = [](const std::string& fields) { return interface::MessageOf([&] { AirOf(fields); }); };
  EXPECT_NE(error("direction: 0 form: UNIFORM windward: 0.2").find("model.air.airwake.speed: missing"),
            std::string::npos);
  EXPECT_NE(error("speed: -3 direction: 0 form: UNIFORM windward: 0.2").find("model.air.airwake.speed"),
            std::string::npos);
  EXPECT_NE(error("speed: 3 direction: 0 windward: 0.2").find("model.air.airwake.form: missing"), std::string::npos);
  std::string m = error("speed: 3 form: UNIFORM windward: 0.2");
  EXPECT_NE(m.find("model.air.airwake.direction: missing; expected the relative wind direction [deg]"),
            std::string::npos)
      << m;
  m = error("speed: 3 direction: 0 form: UNIFORM windward: 0.2 leeward: 0.1");
  EXPECT_NE(m.find("model.air.airwake.leeward: is not read by form UNIFORM; remove it"), std::string::npos) << m;
  m = error("speed: 3 direction: 0 form: LINEAR windward: 0.2 leeward: 0.1");
  EXPECT_NE(m.find("model.air.airwake.length"), std::string::npos) << m;
  m = error("speed: 3 direction: 0 form: STEP windward: 0.2 leeward: 0.1 edge_width: 0");
  EXPECT_NE(m.find("model.air.airwake.edge_width: must be positive"), std::string::npos) << m;
  m = error("speed: 3 direction: 10 form: TABLE grid { x: 0 y: 0 u: -1 }");
  EXPECT_NE(m.find("model.air.airwake.direction: is not read by form TABLE"), std::string::npos) << m;
  m = error("speed: 3 direction: 0 form: UNIFORM windward: 0.2 bow: [1, 0, 1]");
  EXPECT_NE(m.find("model.air.airwake.bow: must be perpendicular to up"), std::string::npos) << m;
}

TEST(AirLoads, AStoppedBladeInAUniformUpwashRestsWhereItsSpringBalancesTheQuasiSteadyLift) {
  // A rigid blade along +y on a flap hinge (axis +x, spring K, damper) in a head wind V with a
  // uniform up-wash k V (model.air.airwake, UNIFORM), the rotor stopped, no gravity, no
  // compressibility. Flapped up by β, the section keeps its chord along x (into the wind: v1 = V)
  // and its upper normal tilts to (0, −sin β, cos β), so v2 = −k V cos β, α = atan(k cos β), and
  // the normal force per span f2 = ½ ρ c v_p (C_l v1 − C_d v2), v_p = V √(1 + k² cos² β), acts at
  // the radius r with the moment r f2 about the hinge (the couple and the spanwise drag have none
  // about it): K β = f2(β) (R² − r0²)/2, solved here by bisection with the same polar. The run,
  // damped, must come to rest there: within 1e-6 rad after 3 s (observed: 0.08678229 rad both,
  // to the 8 digits printed).
  const double V = 20.0, k = 0.1, c = 0.5, r0 = 0.5, R = 5.0, K = 1e4, rho = 1.225;
  char text[2048];
  std::snprintf(text, sizeof text, R"(
    model {
      gravity: [0, 0, 0]
      bodies { name: "blade" mass: 10 inertia: [20.833333333333332, 1e-3, 20.833333333333332] position: [0, 2.5, 0] }
      joints { name: "flap" type: REVOLUTE body1: "ground" body2: "blade" point: [0, 0, 0] axis: [1, 0, 0] }
      forces { name: "spring" joint_spring { joint: "flap" stiffness: %.17g damping: 500 } }
      air { speed_of_sound: 1e9 airwake { speed: %.17g direction: 0 form: UNIFORM windward: %.17g }
        surfaces { name: "b" body: "blade" root: [0, 0, 0] axis: [0, 1, 0] chord: [1, 0, 0] upper: [0, 0, 1]
                   segments: 4 gauss_points: 2
                   stations { s: %.17g chord: %.17g airfoil: "naca0012" }
                   stations { s: %.17g chord: %.17g airfoil: "naca0012" } } }
    }
    numerics { end_time: 3 step: 1e-3 smooth { newton_tolerance: 1e-12 } }
    output { probes { name: "beta" quantity: JOINT_COORDINATE entity: "flap" } })",
                K, V, k, r0, c, R, c);
  MultibodySimulation sim(interface::ScenarioFile::Parse(text, "upwash.pbtxt", {}));
  std::vector<double> v(1);
  for (int n = 0; n < 3000; ++n) sim.Step(n * 1e-3, 1e-3);
  sim.Probe(&v);
  const BuiltinNaca0012 polar;
  auto imbalance = [&](double beta) {
    const double v1 = V, v2 = -k * V * std::cos(beta), vp = std::hypot(v1, v2);
    const double guard = 0.1, phi = 0.5 * rho * c * vp * vp / std::sqrt(vp * vp + guard * guard);
    const PolarValue p = polar.Evaluate(std::atan2(-v2, v1), 0.0);
    return phi * (p.cl * v1 - p.cd * v2) * (R * R - r0 * r0) / 2 - K * beta;
  };
  double lo = 0.0, hi = 0.5;
  ASSERT_GT(imbalance(lo), 0.0);
  ASSERT_LT(imbalance(hi), 0.0);
  for (int i = 0; i < 200; ++i) (imbalance(0.5 * (lo + hi)) > 0 ? lo : hi) = 0.5 * (lo + hi);
  std::printf("blade in a uniform up-wash k = %.2f: β = %.8f rad, the quasi-steady balance %.8f\n", k, v[0], lo);
  EXPECT_GT(lo, 0.05);
  EXPECT_NEAR(v[0], lo, 1e-6);
}

TEST(AirLoads, ASlowlySpinningBladeInAUniformUpwashConesWhereItsSpringAndCentrifugalMomentBalanceTheLift) {
  // The rotor at low speed (Ω = 3 rad/s, 11 % of the Puma's 28): a rigid rod blade (m, R) on a
  // flap hinge at the shaft (spring K, damper), gravity off, no rotor inflow, no compressibility,
  // in a uniform up-wash w (model.air.wind_z): the flow the blade sees is steady, so it comes to
  // rest at the quasi-steady balance K β + Ω² (I_n − I_a) sin β cos β = ∫ r f2 dr. Flapped up by
  // β, a section at r along the blade moves at Ω r cos β along its chord; its velocity point half
  // a chord behind (the 3/4-chord point of the strip theory, air_loads.cpp) has Ω c/2 outwards,
  // which the upper normal (−sin β, 0, cos β) in the blade's plane sees as −(c/2) Ω sin β; so
  // v1 = Ω r cos β, v2 = −(c/2) Ω sin β − w cos β, α = atan2(−v2, v1) (54° at the root, 7.8° at
  // the tip: stalled inboard), and f2 = ½ ρ c v_p²/v_r (C_l v1 − C_d v2) with v_r the guarded
  // speed. The integral by 3-point Gauss on 4000 panels, β by bisection with the same polar; the
  // run, 40 panels of 3 points, damped, ends there to within 1e-6 rad after 4 s (observed:
  // 0.07493494 rad against 0.07493489).
  const double m = 10.0, R = 5.0, r0 = 0.5, c = 0.5, omega = 3.0, w = 2.0, K = 5000.0, rho = 1.225;
  const double Ia = 1e-3, In = m * R * R / 12 + m * R * R / 4;
  char text[4096];
  std::snprintf(text, sizeof text, R"(
    model {
      gravity: [0, 0, 0]
      bodies { name: "hub" mass: 100 inertia: [10, 10, 20] angular_velocity: [0, 0, %.17g] }
      bodies { name: "blade" mass: %.17g inertia: [%.17g, %.17g, %.17g] position: [%.17g, 0, 0]
               velocity: [0, %.17g, 0] angular_velocity: [0, 0, %.17g] }
      joints { name: "shaft" type: REVOLUTE body1: "ground" body2: "hub" point: [0, 0, 0] axis: [0, 0, 1]
               drive { quantity: ANGULAR_SPEED function { constant: %.17g } } }
      joints { name: "flap" type: REVOLUTE body1: "hub" body2: "blade" point: [0, 0, 0] axis: [0, -1, 0] }
      forces { name: "spring" joint_spring { joint: "flap" stiffness: %.17g damping: 500 } }
      air { speed_of_sound: 1e9 wind_z { constant: %.17g }
        surfaces { name: "b" body: "blade" root: [0, 0, 0] axis: [1, 0, 0] chord: [0, 1, 0] upper: [0, 0, 1]
                   segments: 40 gauss_points: 3
                   stations { s: %.17g chord: %.17g airfoil: "naca0012" }
                   stations { s: %.17g chord: %.17g airfoil: "naca0012" } } }
    }
    numerics { end_time: 4 step: 1e-3 smooth { newton_tolerance: 1e-12 } }
    output { probes { name: "beta" quantity: JOINT_COORDINATE entity: "flap" } })",
                omega, m, Ia, m * R * R / 12, m * R * R / 12, R / 2, omega * R / 2, omega, omega, K, w, r0, c, R, c);
  MultibodySimulation sim(interface::ScenarioFile::Parse(text, "spinning_upwash.pbtxt", {}));
  std::vector<double> v(1);
  for (int n = 0; n < 4000; ++n) sim.Step(n * 1e-3, 1e-3);
  sim.Probe(&v);
  const BuiltinNaca0012 polar;
  const double guard = 0.1;
  auto moment = [&](double beta) {  // ∫ r f2 dr over [r0, R]
    const int panels = 4000;
    const double x[3] = {-std::sqrt(0.6), 0.0, std::sqrt(0.6)}, wt[3] = {5.0 / 9, 8.0 / 9, 5.0 / 9};
    const double dr = (R - r0) / panels;
    double sum = 0.0;
    for (int i = 0; i < panels; ++i) {
      for (int g = 0; g < 3; ++g) {
        const double r = r0 + (i + 0.5 * (1.0 + x[g])) * dr;
        const double v1 = omega * r * std::cos(beta), v2 = -0.5 * c * omega * std::sin(beta) - w * std::cos(beta);
        const double vp2 = v1 * v1 + v2 * v2, phi = 0.5 * rho * c * vp2 / std::sqrt(vp2 + guard * guard);
        const PolarValue p = polar.Evaluate(std::atan2(-v2, v1), 0.0);
        sum += 0.5 * dr * wt[g] * r * phi * (p.cl * v1 - p.cd * v2);
      }
    }
    return sum;
  };
  auto imbalance = [&](double beta) {
    return moment(beta) - K * beta - omega * omega * (In - Ia) * std::sin(beta) * std::cos(beta);
  };
  double lo = 0.0, hi = 0.5;
  ASSERT_GT(imbalance(lo), 0.0);
  ASSERT_LT(imbalance(hi), 0.0);
  for (int i = 0; i < 60; ++i) (imbalance(0.5 * (lo + hi)) > 0 ? lo : hi) = 0.5 * (lo + hi);
  std::printf(
      "blade at Ω = %.1f rad/s in a uniform up-wash w = %.1f m/s: β = %.8f rad, the quasi-steady balance %.8f\n", omega,
      w, v[0], lo);
  EXPECT_GT(lo, 0.03);  // coned up by the up-wash, against spring and centrifugal moment
  EXPECT_NEAR(v[0], lo, 1e-6);
}

// A rigid rod blade of mass m hinged on a shaft spinning at 28 rad/s, full-span NACA 0012 at
// pitch θ0 (no compressibility), gravity, no rotor inflow.
std::string FlappingBlade(double m, double theta) {
  const double R = 7.49, omega = 28.0;
  char text[4096];
  std::snprintf(text, sizeof text, R"(
    model {
      gravity: [0, 0, -9.81]
      bodies { name: "hub" mass: 100 inertia: [10, 10, 20] angular_velocity: [0, 0, 28] }
      bodies { name: "blade" mass: %.17g inertia: [1e-3, %.17g, %.17g] position: [%.17g, 0, 0]
               velocity: [0, %.17g, 0] angular_velocity: [0, 0, 28] }
      joints { name: "shaft" type: REVOLUTE body1: "ground" body2: "hub" point: [0, 0, 0] axis: [0, 0, 1]
               drive { quantity: ANGULAR_SPEED function { constant: 28 } } }
      joints { name: "flap" type: REVOLUTE body1: "hub" body2: "blade" point: [0, 0, 0] axis: [0, -1, 0] }
      air { speed_of_sound: 1e9
        surfaces { name: "b" body: "blade" root: [0, 0, 0] axis: [1, 0, 0] chord: [0, 1, 0] upper: [0, 0, 1]
                   segments: 10 gauss_points: 3
                   stations { s: 0 chord: 0.537 twist: %.17g airfoil: "naca0012" }
                   stations { s: 7.49 chord: 0.537 twist: %.17g airfoil: "naca0012" } } }
    }
    numerics { end_time: 2.5 step: 1e-3 smooth { rho_inf: 0.9 ida_relative_tolerance: 1e-9 ida_absolute_tolerance: 1e-11 } }
    output { probes { name: "beta" quantity: JOINT_COORDINATE entity: "flap" } })",
                m, m * R * R / 12, m * R * R / 12, R / 2, omega * R / 2, theta, theta);
  return text;
}

TEST(AirLoads, FlappingBladeHasTheLockNumbersDampingAndConing) {
  // docs/reference/aero.md: a rigid blade hinged on the shaft (e = 0) in hover with full-span air,
  // β'' + (γ/8) β' + ν_β² β = (γ/8) θ0 − g S_β/(I_β Ω²) in ψ = Ω t (λ = 0: no rotor inflow), so
  // the flap mode's damping ratio is γ/(16 ν_β) and the steady coning β0 = (γ/8) θ0/ν_β² −
  // g S_β/(I_β Ω² ν_β²). A uniform rod of R = 7.49 m and chord 0.537 m whose mass gives γ = 2
  // (ζ = 0.125: a clean decay to measure), θ0 = 8°, released at β = 0 at full speed; the
  // built-in NACA 0012 without compressibility (a = 5.7296). CGα at h = 1e-3 s, ρ∞ = 0.9.
  const double R = 7.49, c = 0.537, rho = 1.225, a = 5.7296, omega = 28.0, theta = 8 * kDeg, g = 9.81;
  const double gamma = 2.0, I = rho * a * c * std::pow(R, 4) / gamma, m = 3 * I / (R * R);
  const std::string text = FlappingBlade(m, theta);
  MultibodySimulation sim(interface::ScenarioFile::Parse(text, "flap.pbtxt", {}));
  const double h = 1e-3;
  std::vector<double> beta, v(1);
  for (int k = 0; k < 2500; ++k) {
    sim.Step(k * h, h);
    sim.Probe(&v);
    beta.push_back(v[0]);
  }
  double beta0 = 0.0;
  for (size_t k = 2200; k < 2500; ++k) beta0 += beta[k] / 300.0;
  // The closed forms take the air at the blade's reference line; strip theory takes the normal
  // velocity at the three-quarter chord, c/2 behind it, which on a coned blade moves with
  // −Ω (c/2) sin β across the section: Δα = c β/(2r), a flap moment (γ/8)(2c/(3R)) β in the
  // equation above — a negative spring, ν_β² = 1 − γ c/(12 R) (1.2 % of coning here).
  const double nu_rod = 1.0;  // e = 0, a thin rod
  const double nu = std::sqrt(nu_rod * nu_rod - gamma * c / (12 * R));
  const double beta0_closed = gamma / 8 * theta / (nu * nu) - g * m * R / 2 / (I * omega * omega * nu * nu);
  const double beta0_reference_line = gamma / 8 * theta - g * m * R / 2 / (I * omega * omega);
  // Extrema of β − β0 and the logarithmic decrement between successive ones (half periods).
  std::vector<std::pair<double, double>> extrema;
  for (size_t k = 1; k + 1 < 1500; ++k) {
    const double d0 = beta[k - 1] - beta0, d1 = beta[k] - beta0, d2 = beta[k + 1] - beta0;
    if ((d1 > d0 && d1 >= d2) || (d1 < d0 && d1 <= d2)) extrema.emplace_back(static_cast<double>(k + 1) * h, d1);
  }
  ASSERT_GE(extrema.size(), 4u);
  const double delta = std::log(std::abs(extrema[0].second / extrema[2].second)) / 2;  // per half period
  const double zeta = delta / std::sqrt(kPi * kPi + delta * delta);
  const double wd = kPi * 2 / (extrema[2].first - extrema[0].first);
  const double wn = wd / std::sqrt(1 - zeta * zeta);
  std::printf(
      "flapping blade γ = %.2f: ζ = %.4f (γ/16ν_β = %.4f, %.2f %%), ω_n = %.4f/rev (ν_β %.4f); coning %.5f rad "
      "(closed form %.5f, %.2f %%; with the air at the reference line %.5f)\n",
      gamma, zeta, gamma / (16 * nu), 100 * (zeta / (gamma / (16 * nu)) - 1), wn / omega, nu, beta0, beta0_closed,
      100 * (beta0 / beta0_closed - 1), beta0_reference_line);
  EXPECT_NEAR(zeta / (gamma / (16 * nu)), 1.0, 0.01);
  EXPECT_NEAR(wn / omega, nu, 0.005);
  EXPECT_NEAR(beta0 / beta0_closed, 1.0, 0.002);
}

TEST(AirLoads, FlappingBladeAgreesWithIda) {
  // The same blade released at β = 0, 0.3 s (the first overshoot and back): CGα at h = 1e-3 s
  // and 2.5e-4 s against IDA at 1e-9 — the air loads' Jacobian serves both, and CGα converges
  // to IDA's answer at second order.
  const double R = 7.49, I = 1.225 * 5.7296 * 0.537 * std::pow(R, 4) / 2.0, m = 3 * I / (R * R);
  auto run = [&](const std::vector<std::string>& sets, double h) {
    MultibodySimulation sim(interface::ScenarioFile::Parse(FlappingBlade(m, 8 * kDeg), "flap.pbtxt", sets));
    std::vector<double> v(1);
    const int n = static_cast<int>(std::lround(0.3 / h));
    for (int k = 0; k < n; ++k) sim.Step(k * h, h);
    sim.Probe(&v);
    return v[0];
  };
  const double ida = run({"numerics.smooth.integrator=IDA", "numerics.step=0.01"}, 0.01);
  const double coarse = run({}, 1e-3), fine = run({"numerics.step=2.5e-4"}, 2.5e-4);
  std::printf("flapping blade at 0.3 s: β IDA %.8f, CGα h = 1e-3 %.8f (%.1e), 2.5e-4 %.8f (%.1e)\n", ida, coarse,
              std::abs(coarse - ida), fine, std::abs(fine - ida));
  EXPECT_GT(ida, 0.02);
  EXPECT_LT(std::abs(coarse - ida), 1e-5);                      // measured 1.2e-6 rad
  EXPECT_LT(std::abs(fine - ida), std::abs(coarse - ida) / 8);  // second order: 16 × for 4 × smaller steps
}

TEST(AirLoads, AirfoilsBlendBetweenStations) {
  // Two airfoils along a wing (a table at the root, the built-in NACA 0012 at the tip): a section
  // a quarter of the way out carries ¾ of the first's load and ¼ of the second's (the same flow,
  // chord and frame).
  const std::string table = IdealTable();
  auto wing = [&](const std::string& root, const std::string& tip) {
    return Build(
        "model { bodies { name: \"w\" mass: 1 inertia: [1, 1, 1] }\n"
        "air { airfoils { name: \"ideal\" c81_file: \"" +
        table +
        "\" } wind_y { constant: -40 } wind_z { constant: -3 }\n"
        "surfaces { name: \"s\" body: \"w\" root: [0, 0, 0] axis: [1, 0, 0] chord: [0, 1, 0] upper: [0, 0, 1] "
        "stations { s: 0 chord: 0.4 airfoil: \"" +
        root + "\" } stations { s: 2 chord: 0.4 airfoil: \"" + tip +
        "\" } } } }\n"
        "numerics { end_time: 1 step: 0.1 }");
  };
  const MultibodySystem mixed = wing("ideal", "naca0012"), ideal = wing("ideal", "ideal"),
                        naca = wing("naca0012", "naca0012");
  const Eigen::VectorXd qdot = Eigen::VectorXd::Zero(mixed.coordinates);
  auto load = [&](const MultibodySystem& sys) {
    return sys.air_loads->Evaluate(sys.air_loads->Section(0, 0.5, 1.0), sys.q0, qdot, 0.0, MakeData(sys)).force_local;
  };
  const Eigen::Vector3d expected = 0.75 * load(ideal) + 0.25 * load(naca);
  EXPECT_GT((load(ideal) - load(naca)).norm(), 1.0);
  EXPECT_LT((load(mixed) - expected).norm(), 1e-12 * expected.norm());
}

TEST(AirLoads, ModesOfTheFlappingBladeCarryTheAerodynamicDamping) {
  // The MODES analysis sees the air at the spinning frame's velocities: the same blade as above
  // (no gravity), linearised about its coned equilibrium at Ω = 28 rad/s, has its flap mode at
  // ν_β = √(1 − γc/(12R)) per rev with the damping ratio γ/(16 ν_β) — the time-domain figures
  // above, from a linearisation instead of a decay.
  const double R = 7.49, c = 0.537, rho = 1.225, a = 5.7296, gamma = 2.0, theta = 8 * kDeg;
  const double I = rho * a * c * std::pow(R, 4) / gamma, m = 3 * I / (R * R);
  const std::vector<std::string> modes = {"model.gravity=[0, 0, 0]",        "numerics.start_time=28",
                                          "numerics.end_time=28.1",         "numerics.step=0.1",
                                          "numerics.smooth.analysis=MODES", "numerics.smooth.modes.axis=[0, 0, 1]",
                                          "numerics.smooth.modes.count=1",  "output.probes=[]"};
  ModalSimulation sim(interface::ScenarioFile::Parse(FlappingBlade(m, theta), "flap_modes.pbtxt", modes));
  ASSERT_FALSE(sim.modes().empty());
  const Mode& flap = sim.modes().front().mode;
  const double nu = std::sqrt(1.0 - gamma * c / (12 * R));
  std::printf("flapping blade MODES at 28 rad/s: %.4f/rev (ν_β %.4f), ζ %.4f (γ/16ν_β %.4f)\n", flap.frequency / 28.0,
              nu, flap.damping, gamma / (16 * nu));
  EXPECT_NEAR(flap.frequency / 28.0, nu, 2e-3);
  EXPECT_NEAR(flap.damping / (gamma / (16 * nu)), 1.0, 0.01);
}

TEST(AirLoads, PumaBladeFlapModeHasTheHingeOffsetAndCutOutDamping) {
  // scenarios/puma/blade_fan_plot_air.pbtxt (the articulated elastic Puma blade, NACA 0012 from
  // 2.08 m, no inflow) at Ω100%, compressibility off: the flap mode's damping against aero.md's
  // rigid-blade coefficient (ρ a c Ω/2) ∫_{r0}^{R} r (r − e)² dr over 2 I_β ω (the elastic mode
  // swings its outboard part a little more than a rigid one). Steady state from the flat blade:
  // Newton's capped steps (EquilibriumOptions::max_step) — uncapped, its first step moved the
  // tip 13.8 m and it diverged.
  const auto file = interface::ScenarioFile::Load(
      std::string(COSIM_SOURCE_DIR) + "/scenarios/puma/blade_fan_plot_air.pbtxt",
      {"numerics.start_time=28", "numerics.end_time=28.1", "numerics.step=0.1", "model.air.speed_of_sound=1e9"});
  ModalSimulation sim(file);
  const Mode* flap = nullptr;
  for (const auto& m : sim.modes()) {
    if (flap == nullptr && m.flap > 0.9) flap = &m.mode;
  }
  ASSERT_NE(flap, nullptr);
  const double e = 0.289, r0 = 2.08, R = 7.49, I_beta = 1179.1, omega = 28.0;
  auto F = [&](double r) { return r * r * r * r / 4 - 2 * e * r * r * r / 3 + e * e * r * r / 2; };
  const double damping = 0.5 * 1.225 * 5.7296 * 0.537 * omega * (F(R) - F(r0));
  const double zeta = damping / (2 * I_beta * flap->frequency);
  std::printf(
      "Puma blade in air at 28 rad/s (incompressible): flap %.4f/rev, ζ %.4f (rigid closed form %.4f, %+.1f %%)\n",
      flap->frequency / omega, flap->damping, zeta, 100 * (flap->damping / zeta - 1));
  EXPECT_NEAR(flap->damping / zeta, 1.0, 0.03);
}

TEST(AirLoads, PittPetersInflowBuildsUpWithItsOwnDynamics) {
  // The rigid ideal rotor of the hover test is brought to Ω at t = 0 with no inflow: the
  // Pitt–Peters mean inflow then obeys (128/75π) R ν̇0 + 2 V_T ν0 = T(ν0)/(ρA) (dimensional form
  // of docs/reference/aero.md's λ0 equation, V_T = ν0 in hover). Against an independent RK4
  // integration of that equation with the strip-theory thrust, and its time constant near the
  // end state against the linearised τ = M R / (4 ν̄ − dT/dν/(ρA)) (the mass flow follows ν0 and
  // the thrust falls as ν0 grows). aero.md's 0.543/(2λΩ) is the constant with both held.
  const std::string table = IdealTable();
  const double omega = 28.0, R = 7.49, A = kPi * R * R, rho = 1.225, theta = 5 * kDeg, twist = -8 * kDeg;
  const double M = 128.0 / (75.0 * kPi);
  MultibodySystem sys = Build(RigidRotor("airfoils { name: \"ideal\" c81_file: \"" + table + "\" }", "ideal", theta,
                                         twist, omega, "PITT_PETERS"));
  SystemData data = MakeData(sys);
  const Eigen::VectorXd still = Eigen::VectorXd::Zero(sys.coordinates);
  sys.AcceptStep(sys.q0, still, 0.0, &data);
  const double h = 2e-4;
  const int steps = 5000;
  std::vector<double> nu(steps + 1, 0.0);
  for (int k = 1; k <= steps; ++k) {
    sys.AcceptStep(sys.q0, sys.qdot0, k * h, &data);
    nu[static_cast<size_t>(k)] = sys.air_loads->Rotor(0, sys.q0, sys.qdot0, k * h, data).induced;
  }
  // Independent RK4 of the same equation.
  auto rate = [&](double n) {
    return (StripThrust(n, omega, theta, twist) / (rho * A) - 2 * std::abs(n) * n) / (M * R);
  };
  double x = 0.0, worst = 0.0;
  const double H = 1e-3;
  for (int k = 1; k <= 400; ++k) {
    const double k1 = rate(x), k2 = rate(x + 0.5 * H * k1), k3 = rate(x + 0.5 * H * k2), k4 = rate(x + H * k3);
    x += H / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
    if (k % 5 == 0) worst = std::max(worst, std::abs(nu[static_cast<size_t>(5 * k)] - x));
  }
  double lo = 0.0, hi = 50.0;  // the end state: 2 ρ A ν² = T(ν)
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    (2 * rho * A * mid * mid - StripThrust(mid, omega, theta, twist) > 0 ? hi : lo) = mid;
  }
  const double end = lo;
  // e-folding time from the approach between 10 % and 1 % of the end state.
  double t10 = 0, t1 = 0;
  for (int k = 1; k <= steps; ++k) {
    const double gap = (end - nu[static_cast<size_t>(k)]) / end;
    if (t10 == 0 && gap < 0.1) t10 = k * h;
    if (t1 == 0 && gap < 0.01) t1 = k * h;
  }
  const double tau = (t1 - t10) / std::log(10.0);
  const double dT = (StripThrust(end * 1.001, omega, theta, twist) - StripThrust(end * 0.999, omega, theta, twist)) /
                    (0.002 * end) / (rho * A);
  const double tau_linear = M * R / (4 * end - dT);
  const double lambda = end / (omega * R);
  std::printf(
      "Pitt–Peters hover: ν0 → %.4f m/s (momentum %.4f), largest gap to RK4 %.2e m/s; e-folding %.4f s "
      "(linearised %.4f s, %.2f %%); aero.md's 0.543/(2λΩ) = %.4f s with mass flow and thrust held\n",
      nu.back(), end, worst, tau, tau_linear, 100 * (tau / tau_linear - 1), M / (2 * lambda * omega));
  EXPECT_NEAR(nu.back() / end, 1.0, 1e-4);
  EXPECT_LT(worst, 0.01 * end);
  EXPECT_NEAR(tau / tau_linear, 1.0, 0.03);
}

TEST(AirLoads, BadAirInputNamesThePlace) {
  // Each broken scenario: exit 2 (InputError) with the field and what is expected.
  const std::string body = "bodies { name: \"wing\" mass: 1 inertia: [1, 1, 1] } ";
  const std::string line = "root: [0, 0, 0] axis: [1, 0, 0] chord: [0, 1, 0] ";
  const std::string st =
      "stations { s: 0 chord: 0.3 airfoil: \"naca0012\" } stations { s: 1 chord: 0.3 airfoil: \"naca0012\" }";
  auto scene = [&](const std::string& air) {
    return "model { " + body + "air { " + air + " } } numerics { end_time: 1 step: 0.1 }";
  };
  const std::vector<std::pair<std::string, std::string>> cases = {
      {scene("surfaces { name: \"w\" upper: [0, 0, 1] " + st + " }"), "model.air.surfaces[0]: names no carrier"},
      {scene("surfaces { name: \"w\" body: \"wing\" " + line + "upper: [0, 1, 0] " + st + " }"),
       "model.air.surfaces[0].upper: lies in the chord plane"},
      {scene("surfaces { name: \"w\" body: \"wing\" " + line +
             "upper: [0, 0, 1] stations { s: 0 chord: 0.3 airfoil: \"naca0012\" } }"),
       "needs at least two stations"},
      {scene("surfaces { name: \"w\" body: \"wing\" " + line +
             "upper: [0, 0, 1] stations { s: 0 chord: 0.3 airfoil: \"naca0015\" } stations { s: 1 chord: 0.3 airfoil: "
             "\"naca0012\" } }"),
       "model.air.surfaces[0].stations[0].airfoil"},
      {scene("surfaces { name: \"w\" body: \"wing\" " + line +
             "upper: [0, 0, 1] stations { s: 1 chord: 0.3 airfoil: \"naca0012\" } stations { s: 0.5 chord: 0.3 "
             "airfoil: \"naca0012\" } }"),
       "stations must not decrease"},
      {scene("surfaces { name: \"w\" body: \"wing\" " + line +
             "upper: [0, 0, 1] stations { s: 0 chord: -0.3 airfoil: \"naca0012\" } stations { s: 1 chord: 0.3 airfoil: "
             "\"naca0012\" } }"),
       "model.air.surfaces[0].stations[0].chord"},
      {scene("surfaces { name: \"w\" body: \"wing\" " + line + "upper: [0, 0, 1] gauss_points: 7 " + st + " }"),
       "model.air.surfaces[0].gauss_points"},
      {scene("surfaces { name: \"w\" body: \"ghost\" " + line + "upper: [0, 0, 1] " + st + " }"),
       "model.air.surfaces[0].body"},
      {scene("surfaces { name: \"w\" elastic_body: \"ghost\" " + line + "upper: [0, 0, 1] " + st + " }"),
       "no elastic body named 'ghost'"},
      {scene("airfoils { name: \"t\" c81_file: \"/nonexistent/table.c81\" }"), "model.air.airfoils[0].c81_file"},
      {scene("airfoils { name: \"t\" c81_file: \"t.c81\" builtin_lift_slope: 6 }"),
       "model.air.airfoils[0]: gives both c81_file and builtin_lift_slope"},
      {scene("airfoils { name: \"t\" builtin_lift_slope: -6 }"), "model.air.airfoils[0].builtin_lift_slope"},
      {scene("surfaces { name: \"w\" body: \"wing\" " + line + "upper: [0, 0, 1] " + st +
             " } "
             "rotors { name: \"r\" hub: \"wing\" axis: [0, 0, 1] radius: 1 inflow: PITT_PETERS "
             "induced_velocity_factor: 1.2 surfaces: [\"w\"] }"),
       "model.air.rotors[0].induced_velocity_factor: applies to UNIFORM inflow only"},
      {scene("surfaces { name: \"w\" body: \"wing\" " + line + "upper: [0, 0, 1] " + st +
             " } "
             "rotors { name: \"r\" hub: \"wing\" axis: [0, 0, 1] radius: 1 inflow: UNIFORM "
             "induced_velocity_factor: 0.5 surfaces: [\"w\"] }"),
       "model.air.rotors[0].induced_velocity_factor"},
      {scene("density: -1"), "model.air.density"},
      {scene("gusts { front_direction: [0, 1, 0] direction: [0, 1, 0] front_speed: 10 }"),
       "model.air.gusts[0].profile"},
      {scene("surfaces { name: \"w\" body: \"wing\" " + line + "upper: [0, 0, 1] " + st +
             " } "
             "rotors { name: \"r\" hub: \"wing\" axis: [0, 0, 1] radius: 1 surfaces: [\"w\"] }"),
       "model.air.rotors[0].inflow"},
      {scene("surfaces { name: \"w\" body: \"wing\" " + line + "upper: [0, 0, 1] " + st +
             " } "
             "rotors { name: \"r\" hub: \"wing\" axis: [0, 0, 1] radius: 1 inflow: UNIFORM surfaces: [\"w\", \"w\"] }"),
       "already belongs to rotor 'r'"},
      {scene("surfaces { name: \"w\" body: \"wing\" " + line + "upper: [0, 0, 1] " + st +
             " } "
             "rotors { name: \"r\" hub: \"ground\" axis: [0, 0, 1] radius: 1 inflow: UNIFORM surfaces: [\"w\"] }"),
       "model.air.rotors[0].hub"},
  };
  for (const auto& [text, fragment] : cases) {
    try {
      BuildMultibodyModel(interface::ScenarioFile::Parse(text, "bad.pbtxt", {}));
      ADD_FAILURE() << "accepted; expected: " << fragment;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
  }
  // A C81 file that is malformed: the file and line in the message.
  const std::string bad = WriteFile("bad.c81", "short header\n");
  try {
    BuildMultibodyModel(
        interface::ScenarioFile::Parse(scene("airfoils { name: \"t\" c81_file: \"" + bad + "\" }"), "bad.pbtxt", {}));
    ADD_FAILURE() << "accepted a malformed table";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.c81:1:"), std::string::npos) << e.what();
  }
  // A C81 file that is a FIFO (blocked open() for ever), a device, or 6 GiB (read whole, then
  // "the model does not fit in memory" with no place named): refused by what it is, before it is
  // read, naming the field (the sparse file takes no disk).
  const std::string fifo = WriteFile("fifo.c81", "");
  std::filesystem::remove(fifo);
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::string huge = WriteFile("huge.c81", "");
  std::filesystem::resize_file(huge, 6ULL << 30);
  for (const auto& [file, why] :
       std::vector<std::pair<std::string, std::string>>{{fifo, "is a FIFO, not a regular file"},
                                                        {"/dev/zero", "is a character device, not a regular file"},
                                                        {huge, "has 6442450944 bytes; at most 16777216 are read"}}) {
    const std::string m = interface::MessageOf([&] {
      BuildMultibodyModel(interface::ScenarioFile::Parse(scene("airfoils { name: \"t\" c81_file: \"" + file + "\" }"),
                                                         "bad.pbtxt", {}));
    });
    EXPECT_NE(m.find("model.air.airfoils[0].c81_file: '" + file + "' " + why), std::string::npos) << m;
  }
  std::filesystem::remove(fifo);
  std::filesystem::remove(huge);
}

}  // namespace
}  // namespace cosim::smooth
