// The director-form beam (smooth_solver/beam): exact tangents, stress-free rigid motions, and
// the classic benchmarks with numbers in docs/reference/beams.md — Mattiasson's elastica,
// the roll-up to a full circle, the rotating cantilever's frequencies of Wright et al.
#include "smooth_solver/beam/beam.h"

#include <gtest/gtest.h>

#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "interface/base/errors.h"
#include "smooth_solver/analysis/rotating_frame.h"
#include "smooth_solver/model/multibody_model.h"
#include "smooth_solver/model/multibody_system.h"
#include "smooth_solver/simulation/modal_simulation.h"
#include "smooth_solver/simulation/multibody_simulation.h"
#include "tests/interface/message_of.h"

namespace cosim::smooth {
namespace {

class DenseCollector : public SparseSink {
 public:
  explicit DenseCollector(int n) : m(Eigen::MatrixXd::Zero(n, n)) {}
  void Add(int row, int column, double value) override { m(row, column) += value; }
  Eigen::MatrixXd m;
};

// A cantilever along x from the origin, clamped to the ground at its root.
std::string Cantilever(int elements, int nodes, double ea, double ei, const std::string& extra = "",
                       const std::string& station_extra = "") {
  const std::string st = "ea: " + std::to_string(ea) + " gj: 1 ei_flap: " + std::to_string(ei) +
                         " ei_lag: " + std::to_string(ei) + " mass: 1 inertia_torsion: 1e-4 " + station_extra;
  return "model { beams { name: \"b\" root: [0, 0, 0] axis: [1, 0, 0] chord: [0, 1, 0] elements: " +
         std::to_string(elements) + " nodes_per_element: " + std::to_string(nodes) +
         " root_body: \"ground\" stations { s: 0 " + st + " } stations { s: 1 " + st + " } " + extra +
         " } } numerics { end_time: 1 step: 0.01 }";
}

MultibodySystem Build(const std::string& text, const std::vector<std::string>& sets = {}) {
  const MultibodyModel model = BuildMultibodyModel(interface::ScenarioFile::Parse(text, "beam.pbtxt", sets));
  return BuildMultibodySystem(model);
}

// `text` with the number after every "NAME: " of `names` (digits, signs, points, exponents)
// replaced by 0. (Not std::regex: GCC 12's -Wmaybe-uninitialized fires inside it under the
// sanitizers' -O2, and -Werror stopped the asan preset's unit tests.)
std::string ZeroValues(std::string text, const std::vector<std::string>& names) {
  for (const std::string& name : names) {
    const std::string key = name + ": ";
    for (size_t at = text.find(key); at != std::string::npos; at = text.find(key, at + 1)) {
      const size_t begin = at + key.size();
      size_t end = begin;
      while (end < text.size() && std::string_view("-0123456789.e").find(text[end]) != std::string_view::npos) ++end;
      if (end > begin) text.replace(begin, end - begin, "0");
    }
  }
  return text;
}

TEST(Beam, TangentsMatchFiniteDifferences) {
  // Off the constraint manifold on purpose (the tangent must be exact everywhere), with
  // offsets of the tension centre and Kelvin–Voigt damping: every term of K and C.
  for (int nodes : {2, 3}) {
    const MultibodySystem sys =
        Build(Cantilever(2, nodes, 50.0, 2.0, "retardation_time: 0.3",
                         "tension_chord: 0.05 tension_flap: -0.02 ga_chord: 30 ga_flap: 40 twist: 0.3"));
    const BeamForce& beam = *sys.beam_forces.at(0);
    const SystemData data = MakeData(sys);
    const int n = sys.coordinates;
    Eigen::VectorXd q = sys.q0, qdot(n);
    for (int i = 0; i < n; ++i) {
      q(i) += 0.1 * std::sin(0.7 * i + 0.2);
      qdot(i) = std::cos(1.3 * i);
    }
    DenseCollector K(n), C(n);
    beam.AddTangent(q, qdot, 0.0, data, 1.0, 0.0, &K);
    beam.AddTangent(q, qdot, 0.0, data, 0.0, 1.0, &C);
    const double h = 1e-6;
    double worst_k = 0.0, worst_c = 0.0;
    for (int k = 0; k < n; ++k) {
      Eigen::VectorXd fp = Eigen::VectorXd::Zero(n), fm = Eigen::VectorXd::Zero(n), qp = q, qm = q;
      qp(k) += h;
      qm(k) -= h;
      beam.AddForce(qp, qdot, 0.0, data, fp);
      beam.AddForce(qm, qdot, 0.0, data, fm);
      worst_k = std::max(worst_k, (-(fp - fm) / (2 * h) - K.m.col(k)).lpNorm<Eigen::Infinity>());
      fp.setZero();
      fm.setZero();
      Eigen::VectorXd vp = qdot, vm = qdot;
      vp(k) += h;
      vm(k) -= h;
      beam.AddForce(q, vp, 0.0, data, fp);
      beam.AddForce(q, vm, 0.0, data, fm);
      worst_c = std::max(worst_c, (-(fp - fm) / (2 * h) - C.m.col(k)).lpNorm<Eigen::Infinity>());
    }
    EXPECT_LT(worst_k, 1e-6 * K.m.lpNorm<Eigen::Infinity>()) << nodes << " nodes";
    EXPECT_LT(worst_c, 1e-6 * C.m.lpNorm<Eigen::Infinity>()) << nodes << " nodes";
    EXPECT_GT(C.m.lpNorm<Eigen::Infinity>(), 0.0);
  }
}

TEST(Beam, RigidMotionsAreStressFree) {
  // A pre-twisted beam moved as a rigid body (rotation by 2 rad about a skew axis, and a
  // translation) keeps zero strain energy and zero internal force: the strains are objective.
  const MultibodySystem sys =
      Build(Cantilever(3, 3, 1e3, 5.0, "", "twist: 0.4"), {"model.beams[0].stations[1].twist=-0.5"});
  const Eigen::Matrix3d R = Eigen::AngleAxisd(2.0, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  Eigen::VectorXd q = sys.q0;
  for (int k = 0; k < sys.coordinates / 3; ++k) {
    q.segment<3>(3 * k) = R * Eigen::Vector3d(sys.q0.segment<3>(3 * k));
    if (k % 4 == 0) q.segment<3>(3 * k) += Eigen::Vector3d(0.3, -2, 5);
  }
  Eigen::VectorXd f = Eigen::VectorXd::Zero(sys.coordinates);
  sys.beam_forces[0]->AddForce(q, Eigen::VectorXd::Zero(sys.coordinates), 0.0, MakeData(sys), f);
  EXPECT_LT(f.lpNorm<Eigen::Infinity>(), 1e-10);
  EXPECT_LT(sys.beam_forces[0]->PotentialEnergy(q), 1e-20);
}

// Static cantilever under the scenario's loads, ramped with t from 0 to 1 in `steps`.
EquilibriumResult LoadSteps(const MultibodySystem& sys, int steps) {
  SystemData data = MakeData(sys);
  EquilibriumResult r;
  r.q = sys.q0;
  for (int k = 1; k <= steps; ++k) {
    EquilibriumOptions o;
    o.t = static_cast<double>(k) / steps;
    o.tolerance = 1e-12;
    r = StaticEquilibrium(sys, &data, r.q, SpinningFrame{}, o);
    if (!r.converged) break;
  }
  return r;
}

TEST(Beam, MattiassonElasticaUnderATipDeadLoad) {
  // Inextensible, shear-rigid elastica (beams.md): λ = P L²/EI; EA = GA = 1e7 EI/L² makes the
  // extension and shear 1e-7 of the bending. Mesh: 16 quadratic elements. Tolerance 2e-5 on the
  // tip deflection v/L, shortening (L − x)/L and tip rotation θ. The mesh converges: at λ = 5, v
  // is 0.713912 with 8 elements, 0.713799 with 16 and 0.713792 with 32 (Mattiasson: 0.71379).
  struct Case {
    double lambda, v, shortening, theta;
  };
  for (const Case c : {Case{1, 0.30172, 0.05643, 0.461352}, Case{2, 0.49346, 0.16064, 0.781750},
                       Case{5, 0.71379, 0.38763, 1.215368}}) {
    const std::string load =
        "} forces { name: \"tip\" load { body: \"b.n32\" force { constant: 0 } force { constant: 0 } "
        "force { table { time: [0, 1] value: [0, " +
        std::to_string(-c.lambda) + "] } } } } ";
    // The load block closes `beams` and opens a force element inside `model`.
    std::string text = Cantilever(16, 3, 1e7, 1.0);
    text.replace(text.find(" } } numerics"), 13, " " + load + "} numerics");
    MultibodySystem sys = Build(text);
    const EquilibriumResult r = LoadSteps(sys, 20);
    ASSERT_TRUE(r.converged) << "λ = " << c.lambda;
    const int tip = 32 * kCoordinatesPerBody;
    const Eigen::Vector3d x = r.q.segment<3>(tip), d1 = r.q.segment<3>(tip + 3);
    EXPECT_NEAR(-x.z(), c.v, 2e-5) << "λ = " << c.lambda;
    EXPECT_NEAR(1.0 - x.x(), c.shortening, 2e-5) << "λ = " << c.lambda;
    EXPECT_NEAR(std::atan2(-d1.z(), d1.x()), c.theta, 2e-5) << "λ = " << c.lambda;
  }
}

TEST(Beam, RollsUpIntoAFullCircleUnderATipMoment) {
  // M = 2π EI/L about the chordwise axis bends the cantilever into a circle: the tip comes back
  // to the root and its section has turned by 2π (d1 back along x). 16 quadratic elements.
  std::string text = Cantilever(16, 3, 1e7, 1.0);
  const double M = 2.0 * std::numbers::pi;
  text.replace(text.find(" } } numerics"), 13,
               " } forces { name: \"tip\" load { body: \"b.n32\" torque { constant: 0 } torque { table { time: [0, 1] "
               "value: [0, " +
                   std::to_string(-M) + "] } } torque { constant: 0 } } } } numerics");
  MultibodySystem sys = Build(text);
  const EquilibriumResult r = LoadSteps(sys, 40);
  ASSERT_TRUE(r.converged);
  const int tip = 32 * kCoordinatesPerBody;
  EXPECT_LT(Eigen::Vector3d(r.q.segment<3>(tip)).norm(), 2e-3);
  EXPECT_NEAR(r.q(tip + 3), 1.0, 1e-5);  // d1 · x
  // Halfway the beam is at the top of the circle: x = 0, z = L/π.
  const int mid = 16 * kCoordinatesPerBody;
  EXPECT_NEAR(r.q(mid), 0.0, 2e-3);
  EXPECT_NEAR(r.q(mid + 2), 1.0 / std::numbers::pi, 2e-3);
}

TEST(Beam, RotatingCantileverFrequenciesOfWrightEtAl) {
  // Uniform cantilever (m = EI = L = 1, so λ = Ω) clamped at the spin axis, spinning about z:
  // the first three flapwise (z) frequencies against Wright, Smith, Thresher & Wang (1982),
  // ω̄ = ω √(m L⁴/EI), to 0.5 % (beams.md). Steady state and modes in the spinning frame; 10
  // quadratic elements; EA = GA = 1e7 (inextensible in the reference).
  MultibodySystem sys = Build(Cantilever(10, 3, 1e7, 1.0));
  const double expected[4][3] = {
      {3.5160, 22.0345, 61.6972}, {5.5850, 24.2735, 63.9669}, {9.2569, 29.9959, 70.2936}, {13.1702, 37.6041, 79.6158}};
  for (int c = 0; c < 4; ++c) {
    const double lambda = 4.0 * c;
    SpinningFrame frame;
    frame.omega = Eigen::Vector3d(0, 0, lambda);
    SystemData data = MakeData(sys);
    const EquilibriumResult st = StaticEquilibrium(sys, &data, sys.q0, frame, EquilibriumOptions{});
    ASSERT_TRUE(st.converged) << "λ = " << lambda;
    const std::vector<Mode> modes = LinearModes(sys, data, st.q, st.lambda, 0.0, frame, 40);
    std::vector<double> flap;
    for (const Mode& m : modes) {
      double z = 0.0, other = 0.0;  // motion of the node points out of and in the plane of rotation
      for (int k = 0; k < sys.coordinates; k += kCoordinatesPerBody) {
        z += m.shape(k + 2) * m.shape(k + 2);
        other += m.shape(k) * m.shape(k) + m.shape(k + 1) * m.shape(k + 1);
      }
      if (z > 10.0 * other) flap.push_back(m.frequency);
    }
    ASSERT_GE(flap.size(), 3u) << "λ = " << lambda;
    std::printf("Wright λ = %g: flap %.5f %.5f %.5f\n", lambda, flap[0], flap[1], flap[2]);
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(flap[static_cast<size_t>(k)] / expected[c][k], 1.0, 0.005)
          << "λ = " << lambda << ", flap mode " << k + 1 << ": " << flap[static_cast<size_t>(k)];
    }
  }
}

// A blade as a new user wrote it: L = 5 m, clamped, a root doubler (EI ×3, mass ×2) to s = 1 m
// and a tip weight (mass ×6) from s = 4.5 m, the table stepping at both, under gravity.
std::string SteppedBlade(int elements, const std::string& boundaries) {
  const auto station = [](double s, double ei, double mass) {
    return "stations { s: " + std::to_string(s) + " ea: 1e10 gj: 1e6 ei_flap: " + std::to_string(ei) +
           " ei_lag: " + std::to_string(4 * ei) + " mass: " + std::to_string(mass) + " inertia_torsion: 1e-3 } ";
  };
  return "model { gravity: [0, 0, -9.81] beams { name: \"b\" root: [0, 0, 0] axis: [1, 0, 0] chord: [0, 1, 0] "
         "elements: " +
         std::to_string(elements) + " nodes_per_element: 3 root_body: \"ground\" " + boundaries + station(0, 3e6, 12) +
         station(1, 3e6, 12) + station(1, 1e6, 6) + station(4.5, 1e6, 6) + station(4.5, 1e6, 36) + station(5, 1e6, 36) +
         "} } numerics { end_time: 1 step: 0.01 }";
}

// Euler–Bernoulli's tip droop of that blade: w(L) = ∫₀ᴸ ∫₀ˣ M/EI dξ dx with the root moment
// of the load beyond, M(s) = ∫ₛᴸ m g (σ − s) dσ; trapezoids on 5e4 intervals (M is exact per
// piece, so the error is the quadrature's, ~1e-9).
double SteppedBladeDroop() {
  const double L = 5.0, g = 9.81;
  const auto mass = [](double s) { return s < 1.0 ? 12.0 : (s < 4.5 ? 6.0 : 36.0); };
  const auto ei = [](double s) { return s < 1.0 ? 3e6 : 1e6; };
  // M(s) in closed form per piece: Σ over pieces beyond s of m g ∫ (σ − s) dσ.
  const auto moment = [&](double s) {
    double m = 0.0;
    const double cuts[4] = {0.0, 1.0, 4.5, L};
    for (int p = 0; p < 3; ++p) {
      const double a = std::max(s, cuts[p]), b = cuts[p + 1];
      if (b <= a) continue;
      m += mass(0.5 * (a + b)) * g * 0.5 * ((b - s) * (b - s) - (a - s) * (a - s));
    }
    return m;
  };
  const int n = 50000;
  const double h = L / n;
  double slope = 0.0, droop = 0.0, previous = moment(0.0) / ei(0.0);
  for (int i = 1; i <= n; ++i) {
    const double s = i * h;
    // (ei steps at s = 1 m, a multiple of h: the left piece's value on the left of the cut)
    const double kappa = moment(s) / ei(s - 0.5 * h);
    const double before = slope;
    slope += 0.5 * h * (previous + kappa);
    droop += 0.5 * h * (before + slope);
    previous = moment(s) / ei(s + 0.5 * h);
  }
  return droop;
}

TEST(Beam, ElementBoundariesAtTheTableStepsMakeTheDroopConvergeMonotonically) {
  // Equally long elements sample the stiffness at their Gauss points, so a step inside an element
  // is smeared, on one side or the other as the mesh moves: the new user's blade drooped −7.0 %,
  // +6.1 % and −0.3 % off Euler–Bernoulli at 6, 12 and 24 elements; this one +7.3 %, −1.8 % and
  // −1.7 %. With element_boundaries at the steps each element has one section law: the droop is
  // Euler–Bernoulli's at 6 elements already, within 2.03e-5 at every count (the shear the beam
  // has and Euler–Bernoulli has not: 4 EI/(GA L²) = 1.6e-5), and the first flapwise frequency
  // converges: −1.4e-4 (6 elements) and 3e-6 (12) off the 24-element one.
  const double exact = SteppedBladeDroop();
  const auto solve = [](int elements, const std::string& boundaries, double* frequency) {
    MultibodySystem sys = Build(SteppedBlade(elements, boundaries));
    SystemData data = MakeData(sys);
    EquilibriumOptions o;
    o.tolerance = 1e-12;
    const EquilibriumResult st = StaticEquilibrium(sys, &data, sys.q0, SpinningFrame{}, o);
    EXPECT_TRUE(st.converged) << elements;
    const int tip = 2 * elements * kCoordinatesPerBody;
    if (frequency != nullptr) {
      *frequency = 0.0;
      for (const Mode& m : LinearModes(sys, data, st.q, st.lambda, 0.0, SpinningFrame{}, 10)) {
        if (std::abs(m.shape(tip + 2)) > 10.0 * std::abs(m.shape(tip + 1))) {
          *frequency = m.frequency;  // the lowest mode moving the tip flapwise (z)
          break;
        }
      }
    }
    return -st.q(tip + 2);
  };
  const std::string at_steps = "element_boundaries: [1, 4.5] ";
  double reference = 0.0, f6 = 0.0, f12 = 0.0;
  for (int elements : {6, 12, 24}) {
    double* f = elements == 6 ? &f6 : (elements == 12 ? &f12 : &reference);
    const double equal = solve(elements, "", nullptr), stepped = solve(elements, at_steps, f);
    const double error = stepped / exact - 1.0;
    std::printf("%2d elements: droop %+.3e equal, %+.3e at the steps\n", elements, equal / exact - 1.0, error);
    EXPECT_LT(std::abs(error), 3e-5) << elements;
    EXPECT_GT(std::abs(equal / exact - 1.0), 0.01) << elements;  // (what the boundaries mend)
  }
  std::printf("flap frequency against 24 elements: %+.3e (6), %+.3e (12)\n", f6 / reference - 1.0,
              f12 / reference - 1.0);
  EXPECT_LT(std::abs(f12 / reference - 1.0), 0.1 * std::abs(f6 / reference - 1.0));
  EXPECT_LT(std::abs(f6 / reference - 1.0), 1e-3);
}

TEST(Beam, ElementBoundariesShareTheElementsAmongTheirSegments) {
  // 7 elements over cuts at 1 and 4.5 of a 5 m span (segments of 1, 3.5 and 0.5 m): one each,
  // then each to the segment with the longest elements (3.5, 1.75, 1.17, then 1 against 0.875):
  // 2, 4 and 1 elements, of 0.5, 0.875 and 0.5 m. Out-of-order, outside or too many boundaries
  // are refused naming the field.
  MultibodySystem sys = Build(SteppedBlade(7, "element_boundaries: [1, 4.5] "));
  std::vector<double> x;
  for (int k = 0; k < sys.coordinates; k += kCoordinatesPerBody) x.push_back(sys.q0(k));
  ASSERT_EQ(x.size(), 15u);
  const double ends[8] = {0, 0.5, 1, 1.875, 2.75, 3.625, 4.5, 5};
  for (int e = 0; e <= 7; ++e) EXPECT_NEAR(x[static_cast<size_t>(2 * e)], ends[e], 1e-12) << e;
  for (int e = 0; e < 7; ++e) EXPECT_NEAR(x[static_cast<size_t>(2 * e + 1)], 0.5 * (ends[e] + ends[e + 1]), 1e-12);
  const auto refused = [](int elements, const std::string& boundaries) {
    try {
      Build(SteppedBlade(elements, boundaries));
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(refused(7, "element_boundaries: [4.5, 1] ")
                .find("model.beams[0].element_boundaries[1]: 1 m: expected in "
                      "(4.5, 5) m, after the boundary before it"),
            std::string::npos);
  EXPECT_NE(refused(7, "element_boundaries: [5] ").find("element_boundaries[0]: 5 m: expected in (0, 5) m"),
            std::string::npos);
  EXPECT_NE(refused(2, "element_boundaries: [1, 4.5] ")
                .find("model.beams[0].elements: 2: the 2 element_boundaries cut the span into 3 segments"),
            std::string::npos);
}

TEST(Beam, ClampedFreeShaftTwistsAtItsClosedFormFrequencies) {
  // Uniform clamped–free shaft, GJ = 1 N m², polar mass moment I = 1e-4 kg m, L = 1 m: torsion
  // modes ω_k = (2k − 1) π/(2L) √(GJ/I) = 157.08, 471.24, 785.40 rad/s. A torsion mode turns d2
  // and d3 about the axis: no motion of the node points or of d1. Ten quadratic elements give the
  // first three to 0.1 %. The rotary floor (2 f m = 6e-5 kg m here, ℓ = L/10) must not add to
  // the data's polar moment: the floor of f m on every director did, and put the first torsion
  // mode at 124 rad/s.
  MultibodySystem sys = Build(Cantilever(10, 3, 1e7, 1.0));
  SystemData data = MakeData(sys);
  const EquilibriumResult st = StaticEquilibrium(sys, &data, sys.q0, SpinningFrame{}, EquilibriumOptions{});
  ASSERT_TRUE(st.converged);
  const std::vector<Mode> modes = LinearModes(sys, data, st.q, st.lambda, 0.0, SpinningFrame{}, 40);
  std::vector<double> torsion;
  for (const Mode& m : modes) {
    double bending = 0.0, twist = 0.0;  // points and d1 against d2 and d3
    for (int k = 0; k < sys.coordinates; k += kCoordinatesPerBody) {
      bending += m.shape.segment<6>(k).squaredNorm();
      twist += m.shape.segment<6>(k + 6).squaredNorm();
    }
    if (bending < 1e-6 * twist) torsion.push_back(m.frequency);
  }
  ASSERT_GE(torsion.size(), 3u);
  for (size_t k = 0; k < 3; ++k) {
    const double exact = (2.0 * static_cast<double>(k) + 1.0) * std::numbers::pi / 2.0 * std::sqrt(1.0 / 1e-4);
    std::printf("shaft torsion mode %zu: %.4f rad/s (closed form %.4f)\n", k + 1, torsion[k], exact);
    EXPECT_NEAR(torsion[k] / exact, 1.0, 1e-3) << "torsion mode " << k + 1;
  }
}

TEST(Beam, FlexiblePendulumAgreesInEveryIntegrator) {
  // A beam hinged at its root to the ground, released horizontally under gravity: a large
  // rigid swing with elastic bending (first mode ≈ 35 rad/s, Kelvin–Voigt β = 1e-3 s). The
  // CGα variants (INDEX2_PROJECTED, INDEX3, CGALPHA_INDEX2) at h = 5e-4 s and IDA at tolerances
  // 1e-8 give the same tip: 1.8e-6 m apart after 0.4 s (a 1.3 rad swing of a 1 m beam).
  const std::string st = "ea: 1e5 gj: 50 ei_flap: 100 ei_lag: 300 mass: 1 inertia_torsion: 1e-3 cg_chord: 0.01";
  const std::string base = R"(
    model {
      gravity: [0, 0, -9.81]
      beams { name: "b" root: [0, 0, 0] axis: [1, 0, 0] chord: [0, 1, 0] elements: 5 retardation_time: 1e-3
              stations { s: 0 )" +
                           st + R"( } stations { s: 1 )" + st + R"( } }
      joints { name: "hinge" type: REVOLUTE body1: "ground" body2: "b.n0" point: [0, 0, 0] axis: [0, 1, 0] }
    }
    numerics { end_time: 0.4 step: 5e-4 smooth { rho_inf: 0.9 ida_relative_tolerance: 1e-8 ida_absolute_tolerance: 1e-10 } }
    output {
      probes { name: "tip_x" quantity: POSITION entity: "b.n10" component: X }
      probes { name: "tip_z" quantity: POSITION entity: "b.n10" component: Z }
      probes { name: "strain" quantity: STRAIN_ENERGY entity: "b" }
    })";
  auto run = [&](const std::vector<std::string>& sets) {
    MultibodySimulation sim(interface::ScenarioFile::Parse(base, "pendulum.pbtxt", sets));
    const double h = 5e-4;
    std::vector<double> v(3);
    for (int k = 0; k < 800; ++k) sim.Step(k * h, h);
    sim.Probe(&v);
    return v;
  };
  const std::vector<double> ida = run({"numerics.smooth.integrator=IDA"});
  EXPECT_LT(ida[1], -0.5);  // it has swung down
  EXPECT_GT(ida[2], 1e-4);  // and bends
  for (const auto& sets : std::vector<std::vector<std::string>>{
           {}, {"numerics.smooth.constraint_form=INDEX3"}, {"numerics.smooth.integrator=CGALPHA_INDEX2"}}) {
    const std::vector<double> v = run(sets);
    const double d = std::hypot(v[0] - ida[0], v[1] - ida[1]);
    std::printf("beam pendulum %s: tip (%.6f, %.6f), IDA (%.6f, %.6f), distance %.2e m\n",
                sets.empty() ? "INDEX2_PROJECTED" : sets[0].c_str(), v[0], v[1], ida[0], ida[1], d);
    EXPECT_LT(d, 2e-5) << (sets.empty() ? "default" : sets[0]);  // measured 1.8e-6 m
  }
}

TEST(Beam, CoarseBladesSpinningUnderTheirTensionKeepTheirLength) {
  // Two blades of 3 quadratic elements (the section table of generated rotor 589: EI 2630 N m²
  // flapwise, 30571 N m² lagwise, 5.2 kg/m, a stiffer root and a tip weight) clamped to a hub
  // driven at 54.7 rad/s, gravity on, no air. Their lag mode is at ~0.8/rev, stiffened by the
  // tension (~85 kN at the root); the tip swings ~2 cm in lag as the blades sag. With the axial
  // strain measured along the interpolated director (d1 · r′), the blade could stretch where d1
  // is shorter than 1 between turned sections, without energy: the tension made that a mode of
  // negative stiffness, and the tips went 8 m in lag within 0.1 s, in CGα and IDA alike. The
  // strain of the reference line (½ r′ · r′) has no such mode.
  const std::string table = std::string(COSIM_SOURCE_DIR) + "/tests/data/rotors/teetering_beam_lag/blade_sections.csv";
  auto blade = [&](int k, double sign) {
    const std::string x = std::to_string(sign * 0.2305871882), v = std::to_string(sign * 0.2305871882 * 54.74186195);
    return "beams { name: \"blade" + std::to_string(k) + "\" root: [" + x + ", 0, 0] axis: [" + std::to_string(sign) +
           ", 0, 0] chord: [0, " + std::to_string(sign) +
           ", 0] span_start: 0.2305871882 span_end: 3.543001995 elements: 3 nodes_per_element: 3 "
           "root_body: \"hub\" stations_file: \"" +
           table + "\" velocity: [0, " + v + ", 0] angular_velocity: [0, 0, 54.74186195] } ";
  };
  const std::string scene =
      "model { gravity: [0, 0, -9.81] "
      "bodies { name: \"hub\" mass: 20 inertia: [0.4, 0.4, 0.8] angular_velocity: [0, 0, 54.74186195] } "
      "joints { name: \"shaft\" type: REVOLUTE body1: \"ground\" body2: \"hub\" point: [0, 0, 0] axis: [0, 0, 1] "
      "drive { quantity: ANGULAR_SPEED function { constant: 54.74186195 } } } " +
      blade(1, 1.0) + blade(2, -1.0) +
      "} numerics { end_time: 0.2 step: 2.5e-4 } output { "
      "probes { name: \"lag1\" quantity: POSITION entity: \"blade1.n6\" component: Y frame: \"hub\" } "
      "probes { name: \"lag2\" quantity: POSITION entity: \"blade2.n6\" component: Y frame: \"hub\" } }";
  for (const std::vector<std::string>& sets : {std::vector<std::string>{}, {"numerics.smooth.integrator=IDA"}}) {
    MultibodySimulation sim(interface::ScenarioFile::Parse(scene, "spinning_blades.pbtxt", sets));
    const double h = 2.5e-4;
    std::vector<double> v(2);
    double largest = 0.0;
    for (int k = 0; k < 800; ++k) {
      sim.Step(k * h, h);
      sim.Probe(&v);
      largest = std::max({largest, std::abs(v[0]), std::abs(v[1])});
    }
    std::printf("coarse spinning blades (%s): largest lag at the tip %.4f m\n", sets.empty() ? "CGα" : "IDA", largest);
    EXPECT_LT(largest, 0.03) << (sets.empty() ? "CGα" : "IDA");  // measured 0.017 m; 8 m before
  }
}

TEST(Beam, SectionForcesOfACantileverUnderItsWeight) {
  // Uniform load q = m g on a cantilever: shear q (L − s) and bending moment q (L − s)²/2 at
  // station s, in the section frame (flapwise: Z shear, Y moment). Small load (linear regime),
  // 8 quadratic elements, section forces recovered from the Gauss points: the shear (linear in
  // s) exact, the moment (quadratic) within 0.3 % of the root's.
  std::string text = Cantilever(8, 3, 1e7, 1.0);
  text.replace(text.find("model {"), 7, "model { gravity: [0, 0, -1e-3]");
  MultibodySystem sys = Build(text);
  SystemData data = MakeData(sys);
  const EquilibriumResult r = StaticEquilibrium(sys, &data, sys.q0, SpinningFrame{}, EquilibriumOptions{});
  ASSERT_TRUE(r.converged);
  const double q = 1e-3;
  for (double s : {0.0, 0.1, 0.25, 0.5, 0.8}) {
    const Vector6d sigma = sys.beam_forces[0]->SectionForces(r.q, s);
    // The flapwise axis d3 is +z: gravity bends the beam down (negative curvature about d2 =
    // y, sagging), a shear V3 = −q (L − s) on the outboard part, M2 = −q (L − s)²/2 ... up to the
    // sign convention of the section frame, which the magnitudes do not depend on.
    std::printf("section forces at s = %.2f: V3 %.6e (exact %.6e), M2 %.6e (exact %.6e)\n", s, sigma(2), q * (1 - s),
                sigma(4), 0.5 * q * (1 - s) * (1 - s));
    EXPECT_NEAR(std::abs(sigma(4)), 0.5 * q * (1 - s) * (1 - s), 0.005 * 0.5 * q) << "s = " << s;
    EXPECT_NEAR(std::abs(sigma(2)), q * (1 - s), 1e-6 * q) << "s = " << s;
  }
}

TEST(Beam, PumaBladeMassPropertiesFromItsTables) {
  // The Puma blade of scenarios/puma/rotor_no_air.pbtxt with its beam extended over the tables'
  // whole span (0.28 m to the tip) and laid along x from the rotor axis: the mass matrix's
  // rigid-motion energies give the blade's mass, first moment and inertia about the flap hinge
  // (e = 0.289 m), against puma.md's derived checks 91.6 kg, 247.6 kg m, 1179 kg m² and the
  // rigid flap frequency ratio √(1 + e S_β/I_β) = 1.030. The stations are integrated exactly
  // (data linear between them); the rotary floor adds 2 f m to the bending rotations (≈ 0.02 kg m²).
  const auto file =
      interface::ScenarioFile::Load(std::string(COSIM_SOURCE_DIR) + "/scenarios/puma/rotor_no_air.pbtxt",
                                    {"model.beams[0].span_start=0.28", "model.beams[0].root=[0.28, 0, 0]"});
  const MultibodyModel model = BuildMultibodyModel(file);
  const MultibodySystem sys = BuildMultibodySystem(model);
  const BeamModel& beam = model.beams[0];
  const double e = 0.289;
  const int n = sys.coordinates;
  Eigen::VectorXd lift = Eigen::VectorXd::Zero(n), flap = Eigen::VectorXd::Zero(n);
  for (int node : beam.node_bodies) {
    const int o = kCoordinatesPerBody * node;
    lift(o + 2) = 1.0;  // a unit vertical translation of the blade
    // A unit flap rotation about the hinge axis y through (e, 0, 0): ω × (x − hinge), ω × d.
    const Eigen::Vector3d w = Eigen::Vector3d::UnitY(), hinge(e, 0, 0);
    flap.segment<3>(o) = w.cross(Eigen::Vector3d(sys.q0.segment<3>(o)) - hinge);
    for (int k = 0; k < 3; ++k)
      flap.segment<3>(o + 3 + 3 * k) = w.cross(Eigen::Vector3d(sys.q0.segment<3>(o + 3 + 3 * k)));
  }
  const double mass = lift.dot(sys.mass * lift), first = -lift.dot(sys.mass * flap),
               inertia = flap.dot(sys.mass * flap);
  const double nu = std::sqrt(1.0 + e * first / inertia);
  std::printf("Puma blade: mass %.3f kg, S_beta %.2f kg m, I_beta %.1f kg m^2, nu_beta %.4f\n", mass, first, inertia,
              nu);
  EXPECT_NEAR(mass, 91.6, 0.05);
  EXPECT_NEAR(first, 247.6, 0.05);
  EXPECT_NEAR(inertia, 1179.0, 0.5);
  EXPECT_NEAR(nu, 1.030, 5e-4);
}

TEST(Beam, PumaBladeFlapsAt1030PerRevInItsFanPlot) {
  // The MODES analysis of scenarios/puma/blade_fan_plot.pbtxt (one articulated elastic blade,
  // lag damper) at Ω100% = 28 rad/s only: its flap mode (mostly flap motion, near 1/rev) is the
  // rigid flap frequency ratio ν_β = 1.030 of puma.md, to the blade's elasticity (measured
  // 1.0297); the lag mode sits near 0.24/rev, heavily damped by the lag damper.
  const auto file =
      interface::ScenarioFile::Load(std::string(COSIM_SOURCE_DIR) + "/scenarios/puma/blade_fan_plot.pbtxt",
                                    {"numerics.start_time=28", "numerics.end_time=28.1", "numerics.step=0.1"});
  ModalSimulation sim(file);
  double flap = 0.0, lag = 0.0;
  for (const auto& m : sim.modes()) {
    if (flap == 0.0 && m.flap > 0.9) flap = m.mode.frequency / 28.0;
    if (lag == 0.0 && m.lag > 0.9) lag = m.mode.frequency / 28.0;
  }
  std::printf("Puma blade at 28 rad/s: flap %.4f/rev, lag %.4f/rev\n", flap, lag);
  EXPECT_NEAR(flap, 1.030, 1e-3);
  EXPECT_NEAR(lag, 0.241, 5e-3);
}

TEST(Beam, AModesAnalysisRefusesVisualOutputItWouldWriteEmpty) {
  // A MODES analysis sweeps the spin speed: there is no motion to draw, and its frames were
  // written with no points, which meshio 5 cannot open (Visual.ReadBackWithMeshio reads a frame of
  // every shipped scene). Refused before the sweep, naming the field.
  const std::string scene = std::string(COSIM_SOURCE_DIR) + "/scenarios/puma/blade_fan_plot.pbtxt";
  try {
    ModalSimulation sim(interface::ScenarioFile::Load(scene, {"output.visual.every=1"}));
    FAIL() << "accepted";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("output.visual.every"), std::string::npos) << what;
    EXPECT_NE(what.find("has no motion to draw; leave visual output out (0)"), std::string::npos) << what;
  }
}

TEST(Modes, MoreModesThanTheModelHasOrASettleAreRefusedNamingTheField) {
  // One rigid blade on a flap hinge spinning at 10 to 20 rad/s has one oscillating mode. Asked
  // for three, the run ended 3 ("the solution is no longer finite": the missing modes' columns
  // were NaN) with no row; a settle was ignored in silence (STATIC refuses it). Both exit 2 now.
  const std::string text = R"(
    name: "one_hinge_modes"
    model {
      bodies { name: "blade" mass: 10 inertia: [0.1, 3, 3] position: [2, 0, 0] }
      joints { name: "flap" type: REVOLUTE body1: "ground" body2: "blade" point: [0.5, 0, 0] axis: [0, 1, 0] }
    }
    numerics { start_time: 10 end_time: 20 step: 5 smooth { analysis: MODES modes { count: 3 } } })";
  auto message = [&](const std::vector<std::string>& sets) {
    return interface::MessageOf([&] { ModalSimulation sim(interface::ScenarioFile::Parse(text, "m.pbtxt", sets)); });
  };
  std::string m = message({});
  EXPECT_NE(m.find("numerics.smooth.modes.count: asks for 3 modes; the model has 1 oscillating modes at 10 rad/s: "
                   "ask for at most 1"),
            std::string::npos)
      << m;
  EXPECT_EQ(message({"numerics.smooth.modes.count=1"}), "(no error)");
  m = message({"numerics.smooth.modes.count=1", "numerics.smooth.settle=true"});
  EXPECT_NE(m.find("numerics.smooth.settle: settles the start of a DYNAMIC analysis"), std::string::npos) << m;
}

TEST(Beam, PumaBladeTwistsAtItsTablesOneDimensionalTorsionFrequency) {
  // The oracle: the tables' torsion alone, −(GJ θ')' + Ω² (J22 − J33) θ = ω² (J22 + J33) θ on the
  // beam's span (pitch bearing 0.432 m, held by the rigid pitch link: θ = 0; free tip), J the
  // section's second moments about the reference line, the polar moment floored at 2 f m as the
  // beam floors it (only 0.432–0.604 m, where the tables give none); 4000 linear elements,
  // inverse iteration: 7.49/rev at Ω = 28 rad/s. The MODES analysis of the whole articulated
  // blade (scenarios/puma/blade_fan_plot.pbtxt) without its c.g. offsets and twist, 40 quadratic
  // elements: its torsion mode (the largest share of its kinetic energy in the nodes' twist)
  // within 1 % — the beam samples GJ at its Gauss points, and the root's steps in GJ (8.4e5 to
  // 8.5e4 N m² over 0.6 m) converge unevenly (40 elements +0.5 %, 80 −0.14 %; the scene's blade
  // at 10 elements +0.9 %, at 20 −1.2 %). The scene's own blade (10 elements) within 1.5 %. The old rotary
  // floor, f m on every director, added 2 f m to the polar moment everywhere: 6.78/rev.
  const std::string path = std::string(COSIM_SOURCE_DIR) + "/scenarios/puma/blade_fan_plot.pbtxt";
  const double omega = 28.0;
  // The blade without its chordwise c.g. offsets and twist, which couple torsion to flap and lag
  // (the oracle has torsion alone): the same masses, stiffnesses and polar moments.
  std::ifstream in(path);
  std::stringstream file_text;
  file_text << in.rdbuf();
  const std::string scene = file_text.str();
  const std::string uncoupled = ZeroValues(scene, {"cg_chord", "twist"});
  const std::vector<std::string> speed = {"numerics.start_time=28", "numerics.end_time=28.1", "numerics.step=0.1"};
  const auto torsion_mode = [&](const std::string& text, int elements, double* share) {
    std::vector<std::string> sets = speed;
    sets.push_back("model.beams[0].elements=" + std::to_string(elements));
    ModalSimulation sim(interface::ScenarioFile::Parse(text, path, sets));
    for (const auto& m : sim.modes()) {
      if (m.torsion > std::max({m.flap, m.lag, m.radial})) {
        *share = m.torsion;
        return m.mode.frequency / omega;
      }
    }
    return 0.0;
  };
  const MultibodyModel model = BuildMultibodyModel(interface::ScenarioFile::Parse(uncoupled, path, {}));
  ASSERT_EQ(model.beams.size(), 1u);
  const BeamModel& beam = model.beams[0];
  const double floor = 2.0 * beam.RotaryFloor(beam.elements.front());
  const int n = 4000;  // elements of 1.8 mm: the tip weight's 12 mm step is sampled
  const double a = beam.span_start, h = (beam.span_end - beam.span_start) / n;
  std::vector<Eigen::Triplet<double>> kt, mt;  // nodes 1..n (θ_0 = 0)
  for (int e = 0; e < n; ++e) {
    const BeamSection sec = beam.table.At(a + (e + 0.5) * h);
    const Eigen::Matrix2d J = SectionSecondMoments(sec);
    const double polar = std::max(J.trace(), floor * sec.mass);
    const double propeller = omega * omega * (J(0, 0) - J(1, 1));
    Eigen::Matrix2d k, m;
    k << 1, -1, -1, 1;
    m << 2, 1, 1, 2;
    const Eigen::Matrix2d ke = sec.gj / h * k + propeller * h / 6.0 * m, me = polar * h / 6.0 * m;
    for (int i = 0; i < 2; ++i) {
      for (int j = 0; j < 2; ++j) {
        if (e + i == 0 || e + j == 0) continue;  // the held root
        kt.emplace_back(e + i - 1, e + j - 1, ke(i, j));
        mt.emplace_back(e + i - 1, e + j - 1, me(i, j));
      }
    }
  }
  Eigen::SparseMatrix<double> K(n, n), M(n, n);
  K.setFromTriplets(kt.begin(), kt.end());
  M.setFromTriplets(mt.begin(), mt.end());
  const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(K);
  Eigen::VectorXd x = Eigen::VectorXd::Ones(n);
  for (int it = 0; it < 200; ++it) x = ldlt.solve(M * x).normalized();
  const double oracle = std::sqrt(x.dot(K * x) / x.dot(M * x)) / omega;

  double share = 0.0, scene_share = 0.0;
  const double torsion = torsion_mode(uncoupled, 40, &share), scene_torsion = torsion_mode(scene, 10, &scene_share);
  std::printf(
      "Puma blade torsion at 28 rad/s: %.4f/rev (share %.3f) without c.g. offsets and twist, the tables' 1-D "
      "torsion %.4f/rev; the scene's blade %.4f/rev (share %.3f)\n",
      torsion, share, oracle, scene_torsion, scene_share);
  EXPECT_GT(share, 0.9);
  EXPECT_NEAR(torsion / oracle, 1.0, 0.01);  // measured +0.51 % (80 elements: −0.14 %, 220 s)
  EXPECT_GT(scene_share, 0.9);
  EXPECT_NEAR(scene_torsion / oracle, 1.0, 0.015);  // measured +0.9 %; the old floor's 6.78/rev: −9.5 %
}

TEST(Beam, BadSectionDataIsRefusedWithItsPlace) {
  auto error = [](const std::vector<std::string>& sets) {
    try {
      Build(Cantilever(2, 3, 1e3, 1.0), sets);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  EXPECT_NE(error({"model.beams[0].stations[1].ei_flap=-5"}).find("model.beams[0].stations[1].ei_flap"),
            std::string::npos);
  EXPECT_NE(error({"model.beams[0].stations[1].s=-1"}).find("station out of order"), std::string::npos);
  EXPECT_NE(error({"model.beams[0].root_body=\"hub\""}).find("no body named 'hub'"), std::string::npos);
  EXPECT_NE(error({"model.beams[0].nodes_per_element=4"}).find("expected 2 (linear) or 3"), std::string::npos);
  EXPECT_NE(error({"model.beams[0].chord=[2, 0, 0]"}).find("parallel to axis"), std::string::npos);
  EXPECT_NE(error({"model.beams[0].span_end=3"}).find("span_end"), std::string::npos);
  EXPECT_NE(error({"model.beams[0].stations[0].inertia_flap=1"}).find("more than inertia_torsion"), std::string::npos);
  EXPECT_NE(error({"model.beams[0].elements=0"}).find("1 to 10000 elements"), std::string::npos);
}

}  // namespace
}  // namespace cosim::smooth
