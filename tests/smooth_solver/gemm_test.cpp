// The GEMM midpoint internal force [CGα paper, Eqs. (13)-(19), (30)]: its element-level
// identities (energy, momentum, tangent) and, in the CGα integration of a clamped beam, energy
// conservation with αm = αf = ½, ξ = 0 and the damping of high modes with ρ∞ < 1 or ξ > 0.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <vector>

#include "interface/scenario/scenario_file.h"
#include "smooth_solver/elastic/elastic_model.h"
#include "smooth_solver/elastic/hex27.h"
#include "smooth_solver/integrator/cgalpha.h"
#include "smooth_solver/integrator/initial_conditions.h"
#include "smooth_solver/model/multibody_model.h"
#include "smooth_solver/model/multibody_system.h"
#include "smooth_solver/simulation/multibody_simulation.h"
#include "tests/smooth_solver/skewed_element.h"

namespace cosim::smooth {
namespace {

const ElasticMaterial kAluminium{2700.0, 7e10, 0.33};

// A skewed element and two configurations far apart (strains of a few per cent, a rotation
// of 0.3 rad between them), so that nothing below holds by linearity.
struct TwoConfigurations {
  Hex27 element;
  Hex27::NodeMatrix x0, x1;
  TwoConfigurations() {
    const Hex27::NodeMatrix X = fixtures::SkewedReference();
    EXPECT_TRUE(element.Initialize(X));
    x0 = X;
    x1 = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, -1, 2).normalized()).toRotationMatrix() * X;
    for (int a = 0; a < 27; ++a) {
      x0.col(a) += 0.01 * Eigen::Vector3d(std::sin(a), std::cos(2.0 * a), std::sin(3.0 * a + 1));
      x1.col(a) += 0.01 * Eigen::Vector3d(std::cos(a + 2.0), std::sin(5.0 * a), std::cos(a));
    }
  }
};

TEST(Gemm, MidpointForceWorkIsTheStrainEnergyIncrement) {
  // With αf = ½, ξ = 0: E_{n+1} − E_n = sym(F_mᵀ (F_{n+1} − F_n)) exactly, so
  // f_m · (x_{n+1} − x_n) = ∫ S_m : (E_{n+1} − E_n) = W(x_{n+1}) − W(x_n) (S_m is the mean
  // stress) — an algebraic identity, true to round-off whatever the step. The end-point forces
  // (trapezoidal average) miss it at first order in the strain change.
  TwoConfigurations c;
  Hex27::ElementVector fm, f0, f1;
  c.element.MidpointForce(kAluminium, c.x0, c.x1, {0.5, 0.0}, &fm, nullptr);
  c.element.InternalForce(kAluminium, c.x0, &f0, nullptr);
  c.element.InternalForce(kAluminium, c.x1, &f1, nullptr);
  const Eigen::Map<const Hex27::ElementVector> dx0(c.x0.data()), dx1(c.x1.data());
  const Hex27::ElementVector dx = dx1 - dx0;
  const double dW = c.element.StrainEnergy(kAluminium, c.x1) - c.element.StrainEnergy(kAluminium, c.x0);
  const double gemm_error = std::abs(fm.dot(dx) - dW), trapezoid_error = std::abs(0.5 * (f0 + f1).dot(dx) - dW);
  std::printf("work - ΔW: GEMM %.2e, trapezoid %.2e (ΔW %.3e J)\n", gemm_error, trapezoid_error, dW);
  EXPECT_LT(gemm_error, 1e-11 * std::abs(dW));
  EXPECT_GT(trapezoid_error, 1e-3 * std::abs(dW));
}

TEST(Gemm, MidpointForceConservesLinearAndAngularMomentum) {
  // Σ_a f_m,a = 0 (Σ ∇N_a = 0) and Σ_a x_mid,a × f_m,a = 0 with x_mid = ½ (x_n + x_{n+1}):
  // that is skew(F_m S_m F_mᵀ) = 0 with the symmetric S_m, what makes the scheme conserve
  // angular momentum (αf = ½). Relative to the forces' size.
  TwoConfigurations c;
  Hex27::ElementVector fm;
  c.element.MidpointForce(kAluminium, c.x0, c.x1, {0.5, 0.0}, &fm, nullptr);
  const Hex27::NodeMatrix x_mid = 0.5 * (c.x0 + c.x1);
  Eigen::Vector3d force = Eigen::Vector3d::Zero(), moment = Eigen::Vector3d::Zero();
  for (int a = 0; a < 27; ++a) {
    force += fm.segment<3>(3 * a);
    moment += x_mid.col(a).cross(Eigen::Vector3d(fm.segment<3>(3 * a)));
  }
  const double scale = fm.lpNorm<Eigen::Infinity>();
  EXPECT_LT(force.norm(), 1e-12 * scale);
  EXPECT_LT(moment.norm(), 1e-12 * scale);
}

TEST(Gemm, MidpointTangentMatchesFiniteDifferences) {
  // K = ∂f_m/∂x_{n+1} of Eq. (18) (not symmetric) against central differences, with strain
  // damping on (αf = 0.45, ξ = 0.1) so that every weight of Eqs. (15)-(16) is exercised.
  TwoConfigurations c;
  const MidpointWeights w{0.45, 0.1};
  Hex27::ElementVector f;
  Hex27::ElementMatrix K;
  c.element.MidpointForce(kAluminium, c.x0, c.x1, w, &f, &K);
  EXPECT_GT((K - K.transpose()).lpNorm<Eigen::Infinity>(), 1e-3 * K.lpNorm<Eigen::Infinity>());
  const double eps = 1e-7;
  for (int col = 0; col < 81; ++col) {
    Hex27::NodeMatrix xp = c.x1, xm = c.x1;
    xp(col % 3, col / 3) += eps;
    xm(col % 3, col / 3) -= eps;
    Hex27::ElementVector fp, fm;
    c.element.MidpointForce(kAluminium, c.x0, xp, w, &fp, nullptr);
    c.element.MidpointForce(kAluminium, c.x0, xm, w, &fm, nullptr);
    const Hex27::ElementVector fd = (fp - fm) / (2 * eps);
    ASSERT_LT((fd - K.col(col)).lpNorm<Eigen::Infinity>(), 1e-6 * K.lpNorm<Eigen::Infinity>()) << "column " << col;
  }
}

// A cantilever (0.5 × 0.05 × 0.01 m aluminium, 4 elements) clamped to the ground, set swinging
// by an initial velocity field v_z = 4 m/s (x/L)² (tip amplitude 2 cm: geometrically
// nonlinear) plus a through-thickness stretch rate ∂v_z/∂z = stretch_rate (x/L), which sits in
// stiff modes (ωh ~ 200 at h = 2e-4 s), no gravity. Newton to 1e-10.
struct FreeVibration {
  double energy_drift = 0.0;    // relative change of the total energy after the run
  std::vector<double> stretch;  // through-thickness stretch rate at the tip [m/s], last 20 steps
  int iterations = 0;
};

FreeVibration RunFreeVibration(double rho_inf, bool gemm, double xi, double stretch_rate, int steps) {
  const double h = 2e-4;
  const std::string text = R"(
    name: "free_vibration"
    model {
      elastic_bodies {
        name: "beam"
        material { density: 2700 young: 7e10 poisson: 0.33 }
        beam { length: 0.5 chord: 0.05 thickness: 0.01 elements_along: 4 }
        clamps { body: "ground" face: "root" }
        strain_damping: )" +
                           std::to_string(xi) + R"(
      }
    }
    numerics { end_time: 1 step: 0.001 })";
  const interface::ScenarioFile file = interface::ScenarioFile::Parse(text, "free_vibration.pbtxt", {});
  const MultibodyModel model = BuildMultibodyModel(file);
  std::vector<ElasticBodySpec> elastic =
      BuildElasticBodies(interface::Checks(file), file.proto().model(), model.BodyNames());
  const MultibodySystem sys = BuildMultibodySystem(model, &elastic);
  DaeState s;
  s.q = sys.q0;
  s.qdot = Eigen::VectorXd::Zero(sys.coordinates);
  const int o = sys.elastic_offset[0];
  const ElasticMesh& mesh = sys.elastic[0]->body.mesh();
  int top = -1, bottom = -1;  // tip nodes on the mid-chord line, upper and lower surface
  for (int a : mesh.tip_face) {
    if (std::abs(mesh.nodes(1, a)) > 1e-9) continue;
    if (mesh.nodes(2, a) > 1e-9) top = a;
    if (mesh.nodes(2, a) < -1e-9) bottom = a;
  }
  for (int a = 0; a < mesh.nodes.cols(); ++a) {
    const Eigen::Vector3d X = mesh.nodes.col(a);
    s.qdot(o + 3 * a + 2) = 4.0 * (X.x() / 0.5) * (X.x() / 0.5) + stretch_rate * X.z() * (X.x() / 0.5);
  }
  auto stretch = [&](const DaeState& state) { return state.qdot(o + 3 * top + 2) - state.qdot(o + 3 * bottom + 2); };
  SystemData data = MakeData(sys);
  ConsistentAccelerations(sys, data, 0.0, &s);
  CgAlphaSettings settings;
  settings.rho_inf = rho_inf;
  settings.gemm = gemm;
  settings.tolerance = 1e-10;
  settings.max_iterations = 30;
  CgAlpha integrator(sys, &data, settings, s);
  auto energy = [&](const DaeState& state) { return sys.KineticEnergy(state.qdot) + sys.PotentialEnergy(state.q); };
  const double e0 = energy(s);
  FreeVibration result;
  for (int k = 0; k < steps; ++k) {
    result.iterations += integrator.Step(k * h, h);
    if (k >= steps - 20) result.stretch.push_back(stretch(integrator.state()));
  }
  result.energy_drift = (energy(integrator.state()) - e0) / e0;
  return result;
}

// The through-thickness (stiff) part of the tip's stretch rate at the end of the run: the
// difference between runs with and without the initial stretch rate (the bending motion also
// thickens and thins the section a little), relative to the initial difference, largest over
// the last 20 steps.
double StiffMotionLeft(const FreeVibration& with, const FreeVibration& without, double initial) {
  double worst = 0.0;
  for (size_t k = 0; k < with.stretch.size(); ++k)
    worst = std::max(worst, std::abs(with.stretch[k] - without.stretch[k]));
  return worst / initial;
}

TEST(Gemm, FreeVibrationConservesEnergyWithHalfWeightsAndNoStrainDamping) {
  // αm = αf = ½ (ρ∞ = 1), ξ = 0: the discrete energy balance of the midpoint force (above) with
  // the trapezoidal Newmark update (γ = ½, β = ¼) and clamp rows that do no work makes the
  // kinetic plus strain energy an exact invariant of the step equations; what is left is the
  // Newton tolerance accumulated over 150 steps (about one period of the first bending mode).
  // Observed: 4e-14. The end-point force with the same weights (the trapezoidal rule on a
  // nonlinear force) is not conservative: observed 1e-6.
  const FreeVibration gemm = RunFreeVibration(1.0, true, 0.0, 0.2, 150);
  const FreeVibration endpoint = RunFreeVibration(1.0, false, 0.0, 0.2, 150);
  std::printf("free vibration, rho_inf = 1: energy change GEMM %.2e, end-point %.2e; Newton its %d / %d\n",
              gemm.energy_drift, endpoint.energy_drift, gemm.iterations, endpoint.iterations);
  EXPECT_LT(std::abs(gemm.energy_drift), 1e-11);
  EXPECT_GT(std::abs(endpoint.energy_drift), 1000.0 * std::abs(gemm.energy_drift));
}

TEST(Gemm, NumericalDissipationRemovesHighModes) {
  // ρ∞ = 0.6 (αm ≠ αf) damps the modes with ωh ≫ 1 by ρ∞ per step: 150 steps after an initial
  // through-thickness stretch rate (0.02 m/s across the tip) its stiff motion is gone (0.6^130
  // ~ 1e-29; asserted below 1 %), while with ρ∞ = 1 it is all still there (> 30 %). The bending
  // mode (ωh = 0.04) keeps its energy to 1e-3. Strain damping ξ = 0.1 with ρ∞ = 1 dissipates too
  // (Eq. (17): the extra work ξ ΔE : C : ΔE >= 0 per step) but acts on every mode in proportion
  // to its strain increment, the bending mode included (first order in h, as the paper notes).
  const FreeVibration damped = RunFreeVibration(0.6, true, 0.0, 2.0, 150);
  const FreeVibration damped_reference = RunFreeVibration(0.6, true, 0.0, 0.0, 150);
  const FreeVibration undamped = RunFreeVibration(1.0, true, 0.0, 2.0, 150);
  const FreeVibration undamped_reference = RunFreeVibration(1.0, true, 0.0, 0.0, 150);
  const FreeVibration strain_damped = RunFreeVibration(1.0, true, 0.1, 0.0, 150);
  const double left_damped = StiffMotionLeft(damped, damped_reference, 0.02);
  const double left_undamped = StiffMotionLeft(undamped, undamped_reference, 0.02);
  std::printf(
      "free vibration: stiff motion left rho_inf 0.6: %.1e, rho_inf 1: %.2f; energy change rho_inf 0.6: "
      "%.2e, xi 0.1: %.2e\n",
      left_damped, left_undamped, damped_reference.energy_drift, strain_damped.energy_drift);
  EXPECT_LT(left_damped, 1e-2);
  EXPECT_GT(left_undamped, 0.3);
  EXPECT_LT(damped_reference.energy_drift, 0.0);
  EXPECT_GT(damped_reference.energy_drift, -1e-3);
  EXPECT_LT(strain_damped.energy_drift, -1e-3);
}

TEST(StructuralDamping, ViscousForceIsObjectiveDissipativeAndItsTangentsExact) {
  // Ė = sym(Fᵀ Ḟ) vanishes for a rigid velocity field Ḟ = W F (W skew), so a spinning,
  // deformed element feels no viscous force (to round-off); f_v · v = ∫ Ė : β C : Ė >= 0 for
  // any velocity; ∂f_v/∂x and ∂f_v/∂v against central differences.
  TwoConfigurations c;
  const double beta = 1e-4;
  Eigen::Matrix3d W;
  W << 0, -3, 2, 3, 0, -1, -2, 1, 0;
  Hex27::NodeMatrix v = W * c.x1;
  v.colwise() += Eigen::Vector3d(1, 2, 3);
  Hex27::ElementVector f_rigid, f;
  Hex27::ElementMatrix K, C;
  c.element.ViscousForce(kAluminium, beta, c.x1, v, &f_rigid, 0.0, 0.0, nullptr);
  for (int a = 0; a < 27; ++a) v.col(a) = Eigen::Vector3d(std::sin(a), std::cos(3.0 * a), std::sin(2.0 * a + 1));
  c.element.ViscousForce(kAluminium, beta, c.x1, v, &f, 1.0, 0.0, &K);
  c.element.ViscousForce(kAluminium, beta, c.x1, v, &f, 0.0, 1.0, &C);
  // The rigid field is 3 rad/s on a 0.5 m element, the deforming one ~1 m/s per node.
  EXPECT_LT(f_rigid.lpNorm<Eigen::Infinity>(), 1e-12 * f.lpNorm<Eigen::Infinity>());
  EXPECT_GT(f.dot(Eigen::Map<const Hex27::ElementVector>(v.data())), 0.0);
  const double eps = 1e-7;
  for (int col = 0; col < 81; ++col) {
    Hex27::NodeMatrix xp = c.x1, xm = c.x1, vp = v, vm = v;
    xp(col % 3, col / 3) += eps;
    xm(col % 3, col / 3) -= eps;
    vp(col % 3, col / 3) += eps;
    vm(col % 3, col / 3) -= eps;
    Hex27::ElementVector fp, fm;
    c.element.ViscousForce(kAluminium, beta, xp, v, &fp, 0.0, 0.0, nullptr);
    c.element.ViscousForce(kAluminium, beta, xm, v, &fm, 0.0, 0.0, nullptr);
    ASSERT_LT(((fp - fm) / (2 * eps) - K.col(col)).lpNorm<Eigen::Infinity>(), 1e-6 * K.lpNorm<Eigen::Infinity>())
        << "∂f/∂x column " << col;
    c.element.ViscousForce(kAluminium, beta, c.x1, vp, &fp, 0.0, 0.0, nullptr);
    c.element.ViscousForce(kAluminium, beta, c.x1, vm, &fm, 0.0, 0.0, nullptr);
    ASSERT_LT(((fp - fm) / (2 * eps) - C.col(col)).lpNorm<Eigen::Infinity>(), 1e-6 * C.lpNorm<Eigen::Infinity>())
        << "∂f/∂v column " << col;
  }
}

TEST(StructuralDamping, FirstBendingModeDecaysAtTheKelvinVoigtRatio) {
  // Kelvin–Voigt damping S_v = β C : Ė damps a mode of frequency ω with ζ = βω/2. With
  // β = 1.9e-4 s the first bending mode of a clamped aluminium strip (ω ≈ 210 rad/s) gets
  // ζ ≈ 2 %, its higher modes are overdamped. A 10 N tip load, ramped on over 5 ms and off
  // again at 20 ms, sets it swinging; from 0.03 s on: ω from the zero crossings, ζ from the
  // decay of successive peaks, ln(peak_k / peak_k+1) = 2πζ/√(1 − ζ²), against βω/2. Observed
  // within 1 % (ρ∞ = 0.9 at ωh = 0.1 adds ~1e-5 to ζ); asserted to 3 %.
  const double beta = 1.9e-4, h = 5e-4;
  const std::string text = R"(
    name: "damped_strip"
    model {
      elastic_bodies {
        name: "beam"
        material { density: 2700 young: 7e10 poisson: 0.33 }
        beam { length: 0.5 chord: 0.05 thickness: 0.01 elements_along: 4 }
        clamps { body: "ground" face: "root" }
        retardation_time: )" +
                           std::to_string(beta) + R"(
        loads {
          face_centre: "tip" force: [0, 0, 10]
          factor { table { time: [0, 0.005, 0.015, 0.02] value: [0, 1, 1, 0] } }
        }
      }
    }
    numerics { end_time: 0.12 step: 5e-4 }
    output { probes { name: "tip_z" quantity: DISPLACEMENT entity: "beam" point: "tip_centre" component: Z } })";
  MultibodySimulation sim(interface::ScenarioFile::Parse(text, "damped_strip.pbtxt", {}));
  std::vector<double> z, value(1);
  for (int k = 0; k < 240; ++k) {
    sim.Step(k * h, h);
    sim.Probe(&value);
    z.push_back(value[0]);
  }
  std::vector<double> crossings, peaks;
  for (size_t k = 1; k < z.size(); ++k) {
    if (static_cast<double>(k) * h < 0.03) continue;  // past the first period: the higher modes are gone
    if ((z[k - 1] < 0.0) != (z[k] < 0.0))
      crossings.push_back(h * (static_cast<double>(k - 1) + z[k - 1] / (z[k - 1] - z[k])));
    if (k + 1 < z.size() && z[k] > z[k - 1] && z[k] >= z[k + 1] && z[k] > 0.0) {
      // Parabola through the three samples around the maximum.
      const double a = 0.5 * (z[k - 1] + z[k + 1]) - z[k], b = 0.5 * (z[k + 1] - z[k - 1]);
      peaks.push_back(z[k] - b * b / (4.0 * a));
    }
  }
  ASSERT_GE(peaks.size(), 3u);
  const double omega = M_PI * static_cast<double>(crossings.size() - 1) / (crossings.back() - crossings.front());
  const double decrement = std::log(peaks.front() / peaks.back()) / static_cast<double>(peaks.size() - 1);
  const double zeta = decrement / std::sqrt(4.0 * M_PI * M_PI + decrement * decrement);
  std::printf("structural damping: omega %.2f rad/s, zeta %.5f (beta omega / 2 = %.5f) over %zu peaks\n", omega, zeta,
              0.5 * beta * omega, peaks.size());
  EXPECT_NEAR(zeta, 0.5 * beta * omega, 0.03 * 0.5 * beta * omega);
}

}  // namespace
}  // namespace cosim::smooth

namespace cosim::smooth {
namespace {

TEST(CgAlphaCheckpoint, ARestoredStepIsRepeatedBitForBit) {
  // A coupling iteration repeats the step from its start: after Restore, Step must give
  // exactly what the first attempt gave (elastic GEMM history, α history and the start-up
  // included), and a step tried, undone and tried again equals an uninterrupted run.
  const interface::ScenarioFile file =
      interface::ScenarioFile::Load(std::string(COSIM_SOURCE_DIR) + "/tests/data/flexible_pendulum.pbtxt", {});
  const MultibodyModel model = BuildMultibodyModel(file);
  std::vector<ElasticBodySpec> elastic =
      BuildElasticBodies(interface::Checks(file), file.proto().model(), model.BodyNames());
  const MultibodySystem sys = BuildMultibodySystem(model, &elastic);
  InitialConditionReport report;
  SystemData data = MakeData(sys), straight_data = MakeData(sys);
  const DaeState initial = ConsistentInitialState(sys, data, 0.0, &report);
  CgAlphaSettings settings;
  settings.rho_inf = 0.8;
  CgAlpha tried(sys, &data, settings, initial), straight(sys, &straight_data, settings, initial);
  CgAlpha::Checkpoint start;
  const double h = 1e-3;
  for (int k = 0; k < 4; ++k) {
    tried.SaveTo(&start);
    tried.Step(k * h, h);
    const Eigen::VectorXd first = tried.state().q;
    tried.Restore(start);
    tried.Step(k * h, h);
    EXPECT_EQ(tried.state().q, first) << "step " << k;
    straight.Step(k * h, h);
  }
  EXPECT_EQ(tried.state().q, straight.state().q);
  EXPECT_EQ(tried.state().lambda, straight.state().lambda);
}

}  // namespace
}  // namespace cosim::smooth
