// Force elements in natural coordinates: exact tangents against finite differences, and
// their dynamics against analytic solutions (spring-mass and torsional oscillators, a
// constant torque).
#include "smooth_solver/forces/force_elements.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "smooth_solver/simulation/multibody_simulation.h"

namespace cosim::smooth {
namespace {

class DenseCollector : public SparseSink {
 public:
  explicit DenseCollector(int n) : m(Eigen::MatrixXd::Zero(n, n)) {}
  void Add(int row, int column, double value) override { m(row, column) += value; }
  Eigen::MatrixXd m;
};

// −∂f/∂q and −∂f/∂q̇ by central differences (step 1e-6; agreement ~1e-8 expected).
void ExpectTangentsMatch(const ForceElement& e, const Eigen::VectorXd& q, const Eigen::VectorXd& qdot, double t) {
  const int n = static_cast<int>(q.size());
  const SystemData data;  // (these elements keep no memory in it)
  DenseCollector K(n), C(n);
  e.AddTangent(q, qdot, t, data, 1.0, 0.0, &K);
  e.AddTangent(q, qdot, t, data, 0.0, 1.0, &C);
  const double eps = 1e-6;
  for (int k = 0; k < n; ++k) {
    Eigen::VectorXd fp = Eigen::VectorXd::Zero(n), fm = Eigen::VectorXd::Zero(n);
    Eigen::VectorXd qp = q, qm = q;
    qp(k) += eps;
    qm(k) -= eps;
    e.AddForce(qp, qdot, t, data, fp);
    e.AddForce(qm, qdot, t, data, fm);
    const Eigen::VectorXd fd_k = -(fp - fm) / (2 * eps);
    EXPECT_LT((fd_k - K.m.col(k)).lpNorm<Eigen::Infinity>(), 1e-6 * (1.0 + K.m.lpNorm<Eigen::Infinity>()))
        << "K column " << k;
    fp.setZero();
    fm.setZero();
    Eigen::VectorXd vp = qdot, vm = qdot;
    vp(k) += eps;
    vm(k) -= eps;
    e.AddForce(q, vp, t, data, fp);
    e.AddForce(q, vm, t, data, fm);
    const Eigen::VectorXd fd_c = -(fp - fm) / (2 * eps);
    EXPECT_LT((fd_c - C.m.col(k)).lpNorm<Eigen::Infinity>(), 1e-6 * (1.0 + C.m.lpNorm<Eigen::Infinity>()))
        << "C column " << k;
  }
}

// Two bodies' coordinates, perturbed off orthonormality on purpose (the tangents must be
// exact everywhere, not only on the constraint manifold), and some velocities.
void State(Eigen::VectorXd* q, Eigen::VectorXd* qdot) {
  *q = Eigen::VectorXd(24);
  *qdot = Eigen::VectorXd(24);
  for (int i = 0; i < 24; ++i) {
    (*q)(i) = std::sin(0.7 * i + 0.2) + ((i % 12 == 3 || i % 12 == 7 || i % 12 == 11) ? 1.0 : 0.0);
    (*qdot)(i) = std::cos(1.3 * i);
  }
}

TEST(ForceElements, TangentsMatchFiniteDifferences) {
  Eigen::VectorXd q, qdot;
  State(&q, &qdot);
  std::array<interface::TimeFunction, 3> force{interface::TimeFunction::Constant(1.0),
                                               interface::TimeFunction::Constant(-2.0),
                                               interface::TimeFunction::Constant(0.5)};
  std::array<interface::TimeFunction, 3> torque{interface::TimeFunction::Constant(0.3),
                                                interface::TimeFunction::Constant(0.7),
                                                interface::TimeFunction::Constant(-1.1)};
  ExpectTangentsMatch(AppliedLoad(1, Eigen::Vector3d(0.1, 0.2, -0.3), force, torque, true), q, qdot, 0.0);
  ExpectTangentsMatch(PointSpring(LinearVector::Point(0, Eigen::Vector3d(0.2, 0, 0.1)),
                                  LinearVector::Point(1, Eigen::Vector3d(-0.1, 0.3, 0)), 50.0, 3.0, 0.4),
                      q, qdot, 0.0);
  ExpectTangentsMatch(PointSpring(LinearVector::Point(-1, Eigen::Vector3d(1, 1, 0)),
                                  LinearVector::Point(1, Eigen::Vector3d(0, 0.3, 0)), 20.0, 0.5, 0.0),
                      q, qdot, 0.0);
  const LinearVector b1 = LinearVector::Direction(0, Eigen::Vector3d(1, 0, 0));
  const LinearVector c1 = LinearVector::Direction(0, Eigen::Vector3d(0, 1, 0));
  const LinearVector b2 = LinearVector::Direction(1, Eigen::Vector3d(0.6, 0.8, 0));
  ExpectTangentsMatch(CoordinateSpring(b1, c1, b2, 12.0, 0.8, 0.2), q, qdot, 0.0);
  ExpectTangentsMatch(CoordinateSpring(LinearVector::Point(1, Eigen::Vector3d(0, 0, 0.2)) -
                                           LinearVector::Point(0, Eigen::Vector3d(0.1, 0, 0)),
                                       LinearVector::Direction(0, Eigen::Vector3d(0, 0, 1)), 30.0, 2.0, 0.1),
                      q, qdot, 0.0);
}

double Period(const std::string& text, int probe, double h, double end) {
  MultibodySimulation sim(interface::ScenarioFile::Parse(text, "oscillator", {}));
  std::vector<double> v(1), previous(1);
  sim.Probe(&previous);
  std::vector<double> crossings;
  for (long k = 0; k < std::lround(end / h); ++k) {
    sim.Step(static_cast<double>(k) * h, h);
    sim.Probe(&v);
    if (previous[static_cast<size_t>(probe)] < 0.0 && v[static_cast<size_t>(probe)] >= 0.0) {
      const double t = static_cast<double>(k) * h;
      crossings.push_back(t + h * -previous[0] / (v[0] - previous[0]));
    }
    previous = v;
  }
  return crossings.size() >= 2 ? (crossings.back() - crossings.front()) / static_cast<double>(crossings.size() - 1)
                               : -1.0;
}

TEST(ForceElements, SpringMassOscillatesWithTwoPiSqrtMOverK) {
  // A 2 kg body on a prismatic joint, tied to the ground by a 50 N/m spring (rest length
  // 1 m, stretched to 1.1 m): T = 2π sqrt(m/k) = 1.2566 s. CGα's period error is O(h²):
  // within 1e-4 s at h = 1e-3 (observed in the output).
  const std::string text = R"(
    model {
      bodies { name: "mass" mass: 2 inertia: [0.1, 0.1, 0.1] position: [1.1, 0, 0] }
      joints { name: "slide" type: PRISMATIC body1: "ground" body2: "mass" point: [1.1, 0, 0] axis: [1, 0, 0] }
      forces { name: "spring" spring { body1: "ground" body2: "mass" point1: [0, 0, 0] stiffness: 50 rest_length: 1 } }
    }
    numerics { end_time: 10 step: 0.001 smooth { rho_inf: 0.9 } }
    output { probes { name: "v" quantity: VELOCITY entity: "mass" component: X } })";
  const double T = Period(text, 0, 1e-3, 6.0);
  std::printf("spring-mass period %.6f s (exact %.6f)\n", T, 2 * std::numbers::pi * std::sqrt(2.0 / 50.0));
  EXPECT_NEAR(T, 2 * std::numbers::pi * std::sqrt(2.0 / 50.0), 1e-4);
}

TEST(ForceElements, TorsionalOscillatorOnAJointSpring) {
  // A wheel (I_zz = 0.05 kg m²) on a revolute joint with a 2 N m/rad joint spring, released
  // 0.3 rad from rest: T = 2π sqrt(I/k) = 0.9935 s, within 1e-4 s at h = 1e-3.
  const std::string text = R"(
    model {
      bodies { name: "wheel" mass: 1 inertia: [0.03, 0.03, 0.05] }
      joints { name: "axle" type: REVOLUTE body1: "ground" body2: "wheel" point: [0, 0, 0] axis: [0, 0, 1] }
      forces { name: "torsion" joint_spring { joint: "axle" stiffness: 2 rest_value: 0.3 } }
    }
    numerics { end_time: 10 step: 0.001 smooth { rho_inf: 0.9 } }
    output { probes { name: "w" quantity: JOINT_SPEED entity: "axle" } })";
  const double T = Period(text, 0, 1e-3, 5.0);
  std::printf("torsional period %.6f s (exact %.6f)\n", T, 2 * std::numbers::pi * std::sqrt(0.05 / 2.0));
  EXPECT_NEAR(T, 2 * std::numbers::pi * std::sqrt(0.05 / 2.0), 1e-4);
}

TEST(ForceElements, ConstantTorqueSpinsUpAtTOverI) {
  // A constant torque T = 0.2 N m about the axle of a wheel with I_zz = 0.05 kg m²: the angle
  // is ½ (T/I) t², 2 rad at t = 1 s. In natural coordinates the rotation is not linear in q
  // (the axes turn), so CGα is not exact here but second order: observed errors 5.6e-4 and
  // 1.4e-4 rad at h = 0.01 and 0.005.
  const std::string text = R"(
    model {
      bodies { name: "wheel" mass: 1 inertia: [0.03, 0.03, 0.05] }
      joints { name: "axle" type: REVOLUTE body1: "ground" body2: "wheel" point: [0, 0, 0] axis: [0, 0, 1] }
      forces { name: "motor" load { body: "wheel" torque { constant: 0 } torque { constant: 0 } torque { constant: 0.2 } } }
    }
    numerics { end_time: 1 step: 0.01 smooth { rho_inf: 0.8 newton_tolerance: 1e-12 } }
    output { probes { name: "angle" quantity: JOINT_COORDINATE entity: "axle" } })";
  double error[2];
  int run = 0;
  for (double h : {0.01, 0.005}) {
    MultibodySimulation sim(interface::ScenarioFile::Parse(text, "motor", {}));
    for (long k = 0; k < std::lround(1.0 / h); ++k) sim.Step(static_cast<double>(k) * h, h);
    std::vector<double> v(1);
    sim.Probe(&v);
    error[run++] = std::abs(v[0] - 2.0);
  }
  std::printf("constant torque: angle errors %.2e, %.2e rad\n", error[0], error[1]);
  EXPECT_LT(error[0], 1e-3);
  EXPECT_GT(error[0] / error[1], 3.5);  // second order
}

}  // namespace
}  // namespace cosim::smooth
