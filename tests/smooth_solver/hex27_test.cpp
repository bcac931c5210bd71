// The 27-node Saint Venant–Kirchhoff hexahedron: objectivity, a homogeneous stretch against
// the closed-form stress, the tangent against finite differences, the mass, and the CGα
// paper's cantilever (Section 5.1, Tables 1-2) in a static solve.
#include "smooth_solver/elastic/hex27.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "interface/base/errors.h"
#include "smooth_solver/elastic/elastic_body.h"
#include "smooth_solver/elastic/elastic_model.h"
#include "smooth_solver/integrator/cgalpha.h"
#include "smooth_solver/simulation/elastic_static_simulation.h"
#include "smooth_solver/simulation/multibody_simulation.h"
#include "tests/smooth_solver/skewed_element.h"

namespace cosim::smooth {
namespace {

Hex27::NodeMatrix Reference() { return fixtures::SkewedReference(); }

const ElasticMaterial kSteelLike{7800.0, 2.1e11, 0.3};

TEST(Hex27, RigidMotionGivesNoInternalForce) {
  // Green–Lagrange strain is invariant under rigid motion, so a rotated and translated
  // element carries no stress and no nodal force (to round-off of 1e-4 N on a 2e11 Pa scale).
  Hex27 e;
  ASSERT_TRUE(e.Initialize(Reference()));
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  Hex27::NodeMatrix x = R * Reference();
  x.colwise() += Eigen::Vector3d(1, -2, 0.5);
  Hex27::ElementVector f;
  e.InternalForce(kSteelLike, x, &f, nullptr);
  EXPECT_LT(f.lpNorm<Eigen::Infinity>(), 1e-4);
  EXPECT_NEAR(e.StrainEnergy(kSteelLike, x), 0.0, 1e-12);
}

TEST(Hex27, HomogeneousStretchMatchesTheClosedFormStress) {
  // x = diag(1 + s, 1, 1) X on the axis-aligned 2 m cube: E11 = s + s²/2, S11 = (λ + 2μ) E11,
  // first Piola stress P11 = (1 + s) S11; the nodal forces on the x = +1 face sum to P11 × 4 m².
  // Tri-quadratic elements reproduce the homogeneous field exactly.
  Hex27::NodeMatrix X;
  for (int k = 0; k < 3; ++k) {
    for (int j = 0; j < 3; ++j) {
      for (int i = 0; i < 3; ++i) X.col(i + 3 * j + 9 * k) = Eigen::Vector3d(i - 1.0, j - 1.0, k - 1.0);
    }
  }
  Hex27 e;
  ASSERT_TRUE(e.Initialize(X));
  EXPECT_NEAR(e.Volume(), 8.0, 1e-12);
  const double s = 0.01;
  Hex27::NodeMatrix x = X;
  x.row(0) *= 1.0 + s;
  Hex27::ElementVector f;
  e.InternalForce(kSteelLike, x, &f, nullptr);
  double face = 0.0;
  for (int k = 0; k < 3; ++k) {
    for (int j = 0; j < 3; ++j) face += f(3 * (2 + 3 * j + 9 * k));
  }
  const double E11 = s + 0.5 * s * s;
  const double expected = (1.0 + s) * (kSteelLike.lambda() + 2.0 * kSteelLike.mu()) * E11 * 4.0;
  EXPECT_NEAR(face, expected, 1e-9 * expected);
  EXPECT_NEAR(e.StrainEnergy(kSteelLike, x), 0.5 * (kSteelLike.lambda() + 2.0 * kSteelLike.mu()) * E11 * E11 * 8.0,
              1e-9 * expected);
}

TEST(Hex27, TangentMatchesFiniteDifferences) {
  // K = ∂f_int/∂x, exact; central differences with a 1e-7 m step agree to ~1e-6 relative.
  Hex27 e;
  ASSERT_TRUE(e.Initialize(Reference()));
  Hex27::NodeMatrix x = Reference();
  for (int a = 0; a < 27; ++a)
    x.col(a) += 0.02 * Eigen::Vector3d(std::sin(a), std::cos(2.0 * a), std::sin(3.0 * a + 1));
  Hex27::ElementVector f;
  Hex27::ElementMatrix K;
  e.InternalForce(kSteelLike, x, &f, &K);
  const double eps = 1e-7;
  for (int c = 0; c < 81; ++c) {
    Hex27::NodeMatrix xp = x, xm = x;
    xp(c % 3, c / 3) += eps;
    xm(c % 3, c / 3) -= eps;
    Hex27::ElementVector fp, fm;
    e.InternalForce(kSteelLike, xp, &fp, nullptr);
    e.InternalForce(kSteelLike, xm, &fm, nullptr);
    const Hex27::ElementVector fd = (fp - fm) / (2 * eps);
    ASSERT_LT((fd - K.col(c)).lpNorm<Eigen::Infinity>(), 1e-6 * K.lpNorm<Eigen::Infinity>()) << "column " << c;
  }
}

TEST(Hex27, ConsistentMassSumsToTheElementMass) {
  // Σ_ab M_ab = ρ V for partition-of-unity shape functions.
  Hex27 e;
  ASSERT_TRUE(e.Initialize(Reference()));
  EXPECT_NEAR(e.ScalarMass(7800.0).sum(), 7800.0 * e.Volume(), 1e-9);
}

TEST(Hex27, InvertedElementIsRejected) {
  // Mirroring the node grid turns det J negative at every Gauss point.
  Hex27::NodeMatrix X = Reference();
  X.row(0) *= -1.0;
  Hex27 e;
  EXPECT_FALSE(e.Initialize(X));
}

TEST(Cantilever, StaticTipDisplacementsMatchTables1And2) {
  // The CGα paper's cantilever (Table 1: 1.0 × 0.2 × 0.1 m, E = 1792 GPa, ν = 0.3, one element
  // across, tip load in y at the centre of the tip section), solved statically for 2, 3, 5 and
  // 10 elements along. Table 2 lists the tip displacements its 27-node elements give:
  // uy = 2.68, 2.76, 2.80, 2.83 ×1e-5 m and foreshortening ux = 4.38, 4.59, 4.72, 4.80 ×1e-10 m.
  // Those values are consistent with a 10 kN load (uy = PL³/3EI + shear ≈ 2.8e-5 m for P = 10 kN;
  // the 100 kN printed in Table 1 gives ten times that): the table's load or modulus carries a
  // factor-10 misprint, and the comparison uses 10 kN. Ours: uy 2.6824, 2.7562, 2.8004, 2.8265
  // and ux −4.3632, −4.5772, −4.7045, −4.7784 — within 0.5 % of the table (observed ≤ 0.4 %).
  // Against the paper's "analytic" values (uy 2.83e-5, ux 4.81e-10) the 10-element result is
  // 0.12 % off in uy and 0.66 % in ux (the issue asks 0.5 %: not met for ux; the paper's own
  // 10-element value is 4.80, 0.2 % off, and the "analytic" ux is 0.6 uy²/L of its rounded uy).
  const std::vector<int> elements{2, 3, 5, 10};
  const std::vector<double> table_uy{2.68e-5, 2.76e-5, 2.80e-5, 2.83e-5};
  const std::vector<double> table_ux{4.38e-10, 4.59e-10, 4.72e-10, 4.80e-10};
  for (size_t i = 0; i < elements.size(); ++i) {
    ElasticBody body;
    ASSERT_EQ(body.Initialize(BeamMesh(1.0, 0.2, 0.1, elements[i], 1, 1, {}), ElasticMaterial{1770, 1792e9, 0.3}), -1);
    const StaticResult r =
        SolveStatic(body, body.mesh().root_face, {{body.mesh().tip_centre, Eigen::Vector3d(0, 1e4, 0)}}, 1e-8, 20);
    const Eigen::Vector3d tip = r.displacement.col(body.mesh().tip_centre);
    std::printf("cantilever %2d elements: uy %.4e (table %.2e), ux %.4e (table −%.2e), %d Newton iterations\n",
                elements[i], tip.y(), table_uy[i], tip.x(), table_ux[i], r.iterations);
    EXPECT_NEAR(tip.y(), table_uy[i], 0.005 * table_uy[i]);
    EXPECT_NEAR(-tip.x(), table_ux[i], 0.005 * table_ux[i]);  // foreshortening: the tip moves back
    EXPECT_NEAR(tip.z(), 0.0, 1e-15);
  }
}

TEST(Cantilever, ForeshorteningComesFromTheNonlinearStrainOnly) {
  // Doubling the load doubles uy (linear to 1e-4) but quadruples the foreshortening ux: it is
  // the second-order effect of the Green–Lagrange strain's quadratic term (ux ≈ 0.6 uy²/L).
  ElasticBody body;
  ASSERT_EQ(body.Initialize(BeamMesh(1.0, 0.2, 0.1, 5, 1, 1, {}), ElasticMaterial{1770, 1792e9, 0.3}), -1);
  auto tip = [&](double load) {
    return Eigen::Vector3d(
        SolveStatic(body, body.mesh().root_face, {{body.mesh().tip_centre, Eigen::Vector3d(0, load, 0)}}, 1e-8, 20)
            .displacement.col(body.mesh().tip_centre));
  };
  const Eigen::Vector3d a = tip(1e4), b = tip(2e4);
  EXPECT_NEAR(b.y() / a.y(), 2.0, 2e-4);
  EXPECT_NEAR(b.x() / a.x(), 4.0, 1e-2);
  EXPECT_NEAR(-a.x(), 0.6 * a.y() * a.y(), 0.05 * 0.6 * a.y() * a.y());
}

TEST(ElasticModel, InvertedGeneralMeshIsBadInputNamingTheElement) {
  // A general mesh whose single element lists its nodes mirrored (i reversed) has a negative
  // Jacobian determinant everywhere: refused before any computation, naming the element.
  std::string nodes, order;
  for (int k = 0; k < 3; ++k) {
    for (int j = 0; j < 3; ++j) {
      for (int i = 0; i < 3; ++i) {
        nodes += std::to_string(0.5 * i) + ", " + std::to_string(0.1 * j) + ", " + std::to_string(0.1 * k) + ", ";
        order += std::to_string((2 - i) + 3 * j + 9 * k) + ", ";
      }
    }
  }
  nodes.resize(nodes.size() - 2);
  order.resize(order.size() - 2);
  const std::string text =
      "model { elastic_bodies { name: \"b\" material { density: 1 young: 1e9 poisson: 0.3 } "
      "general { node_coordinates: [" +
      nodes + "] element_nodes: [" + order +
      "] } } }\n"
      "numerics { end_time: 1 step: 1 }";
  const interface::ScenarioFile file = interface::ScenarioFile::Parse(text, "mesh.pbtxt", {});
  try {
    BuildElasticBodies(interface::Checks(file), file.proto().model(), {});
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("element 0 is inverted or degenerate"), std::string::npos) << e.what();
  }
}

TEST(Cantilever, RootLoadsBalanceTheTipLoad) {
  // scenarios/cantilever_static.pbtxt after its 10 load steps: the clamp must supply the
  // opposite of the 10 kN tip load, and about the root centroid the moment of the load arm
  // (1 m, shortened by the 5e-10 m foreshortening): (0, −1e4, 0) N and M_z = −1e4 N m, to the
  // solver's residual (1e-8 relative).
  ElasticStaticSimulation sim(
      interface::ScenarioFile::Load(std::string(COSIM_SOURCE_DIR) + "/scenarios/cantilever_static.pbtxt", {}));
  for (int k = 0; k < 10; ++k) sim.Step(k * 0.1, 0.1);
  std::vector<double> v(5);
  sim.Probe(&v);
  EXPECT_NEAR(v[3], -1e4, 1e-4);
  EXPECT_NEAR(v[4], -1e4, 1e-4);
  EXPECT_NEAR(v[0], 2.8265e-5, 1e-9);  // the same tip deflection as the direct solve
}

TEST(FlexiblePendulum, ClampReactionIsTheBeamsMomentumBalance) {
  // Newton's law for the beam as a whole: the clamp's resultant force on it (from the
  // multipliers, REACTION_FORCE of the elastic body) equals Σ (M q̈) over its nodes minus its
  // weight. It holds because the element's internal forces sum to zero and the step's equations
  // are solved to the Newton tolerance; it checks the probe's rows and sign and the element's
  // self-equilibrium (observed 1.3e-13 N on forces of ~10 N; asserted 1e-10 N).
  auto sim_file =
      interface::ScenarioFile::Load(std::string(COSIM_SOURCE_DIR) + "/tests/data/flexible_pendulum.pbtxt",
                                    {"output.probes=[{name: \"Fz\" quantity: REACTION_FORCE entity: \"beam\" "
                                     "component: Z}, {name: \"Fx\" quantity: REACTION_FORCE entity: \"beam\" "
                                     "component: X}]",
                                     "numerics.smooth.newton_tolerance=1e-10"});
  MultibodySimulation sim(sim_file);
  const MultibodySystem& sys = sim.system();
  const int o = sys.elastic_offset[0], dofs = 3 * sys.elastic[0]->body.node_count();
  const double beam_mass = 2700.0 * 0.5 * 0.05 * 0.01;
  std::vector<double> v(2);
  double worst = 0.0;
  for (int k = 0; k < 100; ++k) {
    sim.Step(k * 0.001, 0.001);
    sim.Probe(&v);
    const DaeState& s = sim.integrator().state();
    const Eigen::VectorXd inertia = sys.mass.block(o, o, dofs, dofs) * s.qddot.segment(o, dofs);
    Eigen::Vector3d total = Eigen::Vector3d::Zero();
    for (int a = 0; a < dofs / 3; ++a) total += inertia.segment<3>(3 * a);
    const Eigen::Vector3d expected = total - beam_mass * Eigen::Vector3d(0, 0, -9.81);
    worst = std::max({worst, std::abs(v[0] - expected.z()), std::abs(v[1] - expected.x())});
  }
  std::printf("flexible pendulum: clamp force vs momentum balance, largest difference %.2e N\n", worst);
  EXPECT_LT(worst, 1e-10);
}

TEST(FlexiblePendulum, RigidAndElasticUnknownsIntegrateTogether) {
  // tests/data/flexible_pendulum.pbtxt: a rigid link hinged to ground carries a beam of
  // 27-node elements clamped to it, released horizontal under gravity. One CGα integration of
  // rigid and elastic coordinates (GEMM midpoint elastic force): over 0.2 s at h = 1e-3 the
  // clamp and hinge constraints hold to 1e-9, the total energy (kinetic, gravity, strain)
  // changes by less than 1e-4 J (ρ∞ = 0.8 damps the stiff through-thickness modes), and the
  // beam swings down (observed hinge angle 0.49 rad and tip z −0.28 m at 0.2 s).
  // (Newton used to fail here from h = 2e-3 on; the cause was the Taylor-shifted starting
  // acceleration, not the light link — see CgAlpha::Step. It now runs at h = 4e-3.)
  MultibodySimulation sim(
      interface::ScenarioFile::Load(std::string(COSIM_SOURCE_DIR) + "/tests/data/flexible_pendulum.pbtxt", {}));
  std::vector<double> v(6), initial(6);
  sim.Probe(&initial);
  double worst_violation = 0.0, worst_energy = 0.0;
  for (int k = 0; k < 200; ++k) {
    sim.Step(k * 0.001, 0.001);
    sim.Probe(&v);
    worst_violation = std::max(worst_violation, v[5]);
    worst_energy = std::max(worst_energy, std::abs(v[4] - initial[4]));
  }
  std::printf("flexible pendulum: hinge %.4f rad, tip z %.4f m, energy change %.2e J, violation %.1e\n", v[0], v[1],
              worst_energy, worst_violation);
  EXPECT_LT(worst_violation, 1e-9);
  EXPECT_LT(worst_energy, 1e-4);
  EXPECT_GT(v[0], 0.4);
  EXPECT_LT(v[1], -0.2);
}

}  // namespace
}  // namespace cosim::smooth

namespace cosim::smooth {
namespace {

TEST(FlexiblePendulum, SecondOrderInTimeForTipPositionAndRootReactions) {
  // The flexible pendulum with Kelvin–Voigt damping β = 1e-3 s (ζ ≈ 10 % in the first bending
  // mode, the mesh's stiff modes overdamped): released under gravity, every mode the release
  // excites is then either resolved by the step or dies out, and the solution at 0.2 s
  // converges at second order in h — the tip position and the multipliers: the clamp's root
  // force and moment and the hinge force. Orders from successive differences over
  // h = 1e-3, 5e-4, 2.5e-4 s, Newton to 1e-10: observed 2.1 for the reactions and 2.6 for the
  // tip (differences of 1e-7 m; at least second order is what is asserted); 2.1 .. 2.4 down to
  // h = 1.25e-4 against a 6.25e-5 reference. (At 0.1 s the start-up transient still decays and
  // the differences shrink faster: orders 3.5 .. 4.5.) Undamped (β = 0), the reactions do not converge
  // pointwise at these steps: each halving resolves more of the beam's modes that the sudden
  // release excited, which ρ∞ < 1 had damped at the larger step (observed erratic orders);
  // the tip position alone shows order ~2 below h = 5e-4.
  const std::vector<double> steps{1e-3, 5e-4, 2.5e-4};
  const std::vector<std::string> settings{
      "model.elastic_bodies[0].retardation_time=1e-3", "numerics.smooth.newton_tolerance=1e-10",
      "output.probes=[{name: \"tip_z\" quantity: DISPLACEMENT entity: \"beam\" point: \"tip_centre\" component: Z}, "
      "{name: \"root_fz\" quantity: REACTION_FORCE entity: \"beam\" component: Z}, "
      "{name: \"root_my\" quantity: REACTION_MOMENT entity: \"beam\" component: Y}, "
      "{name: \"hinge_fz\" quantity: REACTION_FORCE entity: \"hinge\" component: Z}]"};
  const std::string path = std::string(COSIM_SOURCE_DIR) + "/tests/data/flexible_pendulum.pbtxt";
  std::vector<std::vector<double>> results;
  for (double h : steps) {
    MultibodySimulation sim(interface::ScenarioFile::Load(path, settings));
    const int n = static_cast<int>(std::lround(0.2 / h));
    for (int k = 0; k < n; ++k) sim.Step(k * h, (k + 1) * h - k * h);
    std::vector<double> v(4);
    sim.Probe(&v);
    results.push_back(v);
  }
  // The independent reference: IDA (variable order and step, tolerances 1e-10) on the
  // end-point (continuous) elastic force, against CGα Richardson-extrapolated from the two
  // finest steps. Observed: 1e-8 m at the tip and 3.5e-7 N on the 4.7 N reactions; asserted
  // 3e-7 m and 3e-5 N. (With tolerances 1e-8 IDA's reactions were 8e-6 N off, and 5e-5 N after a
  // change of the element tangent's rounding alone: IDA's λ follows its step history.) The output grid is
  // t_k = k h as the run driver steps it: stepping IDA by t_k + h instead (ends off the grid
  // by an ulp) sent it, on this very stiff model (overdamped through-thickness modes at
  // ~1e8 1/s), into 5e-6 s steps and a 2.6e-3 N error on λ (IDA's λ = dΛ/dt is not error
  // controlled) — the reference is only as good as IDA's step history.
  std::vector<std::string> ida_settings = settings;
  ida_settings.insert(ida_settings.end(),
                      {"numerics.smooth.integrator=IDA", "numerics.smooth.ida_relative_tolerance=1e-10",
                       "numerics.smooth.ida_absolute_tolerance=1e-10"});
  MultibodySimulation ida(interface::ScenarioFile::Load(path, ida_settings));
  for (int k = 0; k < 200; ++k) ida.Step(k * 1e-3, (k + 1) * 1e-3 - k * 1e-3);
  std::vector<double> reference(4);
  ida.Probe(&reference);
  const char* names[] = {"tip z", "root force z", "root moment y", "hinge force z"};
  for (int p = 0; p < 4; ++p) {
    const double d1 = std::abs(results[0][p] - results[1][p]), d2 = std::abs(results[1][p] - results[2][p]);
    const double order = std::log2(d1 / d2);
    std::printf("flexible pendulum %s at 0.2 s: %.8e, differences %.2e %.2e, order %.2f\n", names[p], results[2][p], d1,
                d2, order);
    EXPECT_GT(order, 1.8) << names[p];
    EXPECT_LT(order, 3.0) << names[p];
    const double extrapolated = results[2][p] + (results[2][p] - results[1][p]) / 3.0;
    std::printf("  CGα extrapolated %.9e, IDA %.9e, difference %.1e\n", extrapolated, reference[p],
                extrapolated - reference[p]);
    EXPECT_NEAR(extrapolated, reference[p], p == 0 ? 3e-7 : 3e-5) << names[p];
  }
}

}  // namespace
}  // namespace cosim::smooth

namespace cosim::smooth {
namespace {

// A hub spun up to 20 rad/s in 0.1 s, with two aluminium blades (0.5 m × 50 mm × 20 mm, five
// elements) clamped to it: 80 steps of 2 ms turn it by 2.2 rad.
std::string SpinningHub(double speed) {
  std::string hub = R"(
    name: "spinning_hub"
    model {
      bodies { name: "hub" mass: 20 inertia: [0.3, 0.3, 0.5] position: [0, 0, 0] }
      joints {
        name: "shaft" type: REVOLUTE body1: "ground" body2: "hub" point: [0, 0, 0] axis: [0, 0, 1]
        drive { quantity: ANGULAR_SPEED function { cosine_ramp { final_value: )" +
                    std::to_string(speed) + R"( ramp_time: 0.1 } } }
      })";
  for (int b = 0; b < 2; ++b) {
    hub += std::string(R"(
      elastic_bodies {
        name: "blade)") +
           std::to_string(b) + R"("
        material { density: 2700 young: 7e10 poisson: 0.33 }
        beam { length: 0.5 chord: 0.05 thickness: 0.02 elements_along: 5 root: )" +
           (b == 0 ? "[0.1, 0, 0] axis: [1, 0, 0]" : "[-0.1, 0, 0] axis: [-1, 0, 0]") + R"( }
        clamps { body: "hub" face: "root" }
        retardation_time: 1e-4
      })";
  }
  hub += R"(
      gravity: [0, 0, -9.81]
    }
    numerics { end_time: 0.16 step: 0.002 }
    output {
      probes { name: "tip_z" quantity: DISPLACEMENT entity: "blade0" point: "tip_centre" component: Z frame: "hub" }
      probes { name: "root_x" quantity: REACTION_FORCE entity: "blade0" component: X frame: "hub" }
    })";
  return hub;
}

struct HubRun {
  std::vector<double> probes;
  long long factorizations = 0;
};

HubRun RunHub(const std::vector<std::string>& sets) {
  MultibodySimulation sim(interface::ScenarioFile::Parse(SpinningHub(20.0), "spinning_hub.pbtxt", sets));
  for (int k = 0; k < 80; ++k) sim.Step(k * 0.002, (k + 1) * 0.002 - k * 0.002);
  HubRun r;
  r.probes.resize(2);
  sim.Probe(&r.probes);
  r.factorizations = dynamic_cast<const CgAlpha&>(sim.integrator()).factorizations();
  return r;
}

TEST(CoRotatedReuse, ASpinningElasticHubReusesItsMatrixAcrossAzimuthsForTheSameAnswer) {
  // In absolute coordinates a blade's stiff axial modes turn with the hub: a Newton matrix from
  // one azimuth stops contracting once the hub has turned by about the bending-to-axial stiffness
  // ratio. Carried along with the hub's rotation (numerics.smooth.jacobian_frame), the matrix of
  // a steadily spinning rotor stays the matrix at every azimuth, so it is reused over the whole
  // turn, and the modified-Newton acceptance (estimated error below 1e-3 of the tolerance) keeps
  // the answer full Newton's.
  // Observed: 160 factorisations with full Newton, 177 reused unrotated (the matrix is useless a
  // few steps later), 12 co-rotated; the tip 3e-8 m and the root's radial force 4e-4 N (2e-6 of
  // it) from full Newton's, whose own Newton tolerance is 1.6e-6 m.
  const HubRun full = RunHub({});
  const HubRun plain = RunHub({"numerics.smooth.jacobian_max_age=1000"});
  const HubRun turned = RunHub({"numerics.smooth.jacobian_max_age=1000", "numerics.smooth.jacobian_frame=hub"});
  std::printf(
      "spinning hub, 80 steps: factorisations full %lld, reused %lld, co-rotated %lld; tip_z %.9e / %.9e / "
      "%.9e m, root_x %.6f / %.6f / %.6f N\n",
      full.factorizations, plain.factorizations, turned.factorizations, full.probes[0], plain.probes[0],
      turned.probes[0], full.probes[1], plain.probes[1], turned.probes[1]);
  EXPECT_LT(turned.factorizations * 10, full.factorizations);
  EXPECT_LT(turned.factorizations * 3, plain.factorizations);
  EXPECT_NEAR(turned.probes[0], full.probes[0], 1e-7);
  EXPECT_NEAR(turned.probes[1], full.probes[1], 1e-5 * std::abs(full.probes[1]));
}

TEST(CoRotatedReuse, AFrameThatIsNoBodyOrWithoutReuseIsRefusedWithItsPlace) {
  for (const auto& sets :
       {std::vector<std::string>{"numerics.smooth.jacobian_max_age=5", "numerics.smooth.jacobian_frame=rotor"},
        std::vector<std::string>{"numerics.smooth.jacobian_frame=hub"}}) {
    try {
      MultibodySimulation sim(interface::ScenarioFile::Parse(SpinningHub(20.0), "spinning_hub.pbtxt", sets));
      ADD_FAILURE() << "accepted " << sets.back();
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("numerics.smooth.jacobian_frame"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace cosim::smooth
