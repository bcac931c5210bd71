// The contact side of the interface Jacobians (docs/protocol.md): the sensitivity of a node's end
// velocity to a constant force on it, against finite differences of the step itself on each piece
// of the contact problem (free, resting, sliding with friction, sticking, in a wedge); and the
// coordinator's stiffness law, which must leave the node where the force it reports leaves it.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <string>
#include <vector>

#include "interface/scenario/scenario_file.h"
#include "nonsmooth_solver/integrator/moreau_jean.h"
#include "tests/nonsmooth_solver/contact_scene.h"

namespace cosim::nonsmooth {
namespace {

// A 0.2 kg node, `contacts` its contact clauses, pushed by `push` (N) besides gravity.
ContactScene NodeModel(const std::string& contacts, const std::vector<std::string>& sets = {}) {
  const std::string text = R"(
    model {
      gravity: [0, 0, -9.81]
      obstacles { name: "floor" point: [0, 0, 0] normal: [0, 0, 1] }
      obstacles { name: "wall" point: [0, 0, 0] normal: [0.6, 0, 0.8] }
      contact_nodes { name: "n" mass: 0.2 position: [0.1, 0.05, 0.0] velocity: [0.3, -0.2, 0] )" +
                           contacts + R"( }
    }
    numerics { end_time: 1 step: 0.001 }
  )";
  return LoadContactScene(text, "jacobian", sets);
}

// The end velocity of one step from the model's start with the constant force f.
Eigen::Vector3d EndVelocity(const ContactScene& model, const Eigen::Vector3d& f, double h) {
  MoreauJean mj(model, model.settings, 0.0);
  mj.SetExternalForces(f);
  mj.Step(0.0, h);
  return mj.velocities().head<3>();
}

// ∂v/∂f by central differences (the map is affine on a piece: exact up to round-off).
Eigen::Matrix3d FiniteDifference(const ContactScene& model, const Eigen::Vector3d& f, double h, double df) {
  Eigen::Matrix3d d;
  for (int j = 0; j < 3; ++j) {
    const Eigen::Vector3d e = df * Eigen::Vector3d::Unit(j);
    d.col(j) = (EndVelocity(model, f + e, h) - EndVelocity(model, f - e, h)) / (2.0 * df);
  }
  return d;
}

Eigen::Matrix3d Sensitivity(const ContactScene& model, const Eigen::Vector3d& f, double h) {
  MoreauJean mj(model, model.settings, 0.0);
  mj.set_compute_sensitivities(true);
  mj.SetExternalForces(f);
  mj.Step(0.0, h);
  return Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(mj.velocity_sensitivity().data());
}

struct Piece {
  const char* what;
  std::string contacts;
  std::vector<std::string> sets;
  Eigen::Vector3d force;
};

TEST(InterfaceJacobian, NodeSensitivityIsTheStepsOwnDerivativeOnEachPieceOfTheContactProblem) {
  // Each case is inside one piece (the forces are far from switching the contact set), so the
  // central difference of the step is its derivative to round-off; the analytic sensitivity
  // must agree to 1e-7 of a free node's h/m. The resting node's normal row must be zero: the floor
  // takes any extra downward push.
  const double h = 1e-3;
  const std::vector<Piece> pieces = {
      {"free flight", R"(contacts { obstacle: "floor" restitution: 0.5 })", {}, {0, 0, 10}},
      {"resting, frictionless", R"(contacts { obstacle: "floor" restitution: 0.5 })", {}, {1, 2, -5}},
      {"resting in a wedge",
       R"(contacts { obstacle: "floor" restitution: 0 } contacts { obstacle: "wall" restitution: 0 })",
       {},
       {-3, 1, -5}},
      {"sliding, polyhedral cone", R"(contacts { obstacle: "floor" restitution: 0 friction: 0.3 })", {}, {0, 0, -5}},
      {"sticking, polyhedral cone",
       R"(contacts { obstacle: "floor" restitution: 0 friction: 0.9 })",
       {"model.contact_nodes[0].velocity=[0.0001, 0, 0]"},
       {0.2, 0.1, -5}},
      {"sliding, fc3d",
       R"(contacts { obstacle: "floor" restitution: 0 friction: 0.3 })",
       {"numerics.nonsmooth.friction_model=SICONOS_FC3D", "numerics.nonsmooth.lcp.tolerance=1e-15"},
       {0, 0, -5}},
      {"sticking, fc3d",
       R"(contacts { obstacle: "floor" restitution: 0 friction: 0.9 })",
       {"numerics.nonsmooth.friction_model=SICONOS_FC3D", "model.contact_nodes[0].velocity=[0.0001, 0, 0]"},
       {0.2, 0.1, -5}},
  };
  for (const Piece& p : pieces) {
    SCOPED_TRACE(p.what);
    const ContactScene model = NodeModel(p.contacts, p.sets);
    const Eigen::Matrix3d analytic = Sensitivity(model, p.force, h);
    const Eigen::Matrix3d numeric = FiniteDifference(model, p.force, h, 1e-4);
    EXPECT_LE((analytic - numeric).norm(), 1e-7 * std::max(analytic.norm(), h / 0.2))
        << "analytic\n"
        << analytic << "\nfinite differences\n"
        << numeric;
  }
  // The free node: h/m on the diagonal; resting on the floor: nothing along z.
  const Eigen::Matrix3d free = Sensitivity(NodeModel(pieces[0].contacts), pieces[0].force, h);
  EXPECT_NEAR(free(0, 0), h / 0.2, 1e-15);
  const Eigen::Matrix3d rest = Sensitivity(NodeModel(pieces[1].contacts), pieces[1].force, h);
  EXPECT_NEAR(rest.row(2).norm() + rest.col(2).norm(), 0.0, 1e-15);
  EXPECT_NEAR(rest(0, 0), h / 0.2, 1e-15);
}

TEST(InterfaceJacobian, TheStiffnessLawLeavesTheNodeWhereItsReportedForceDoes) {
  // With the coordinator's law f = f̂ + E (q_end − x̂), taken implicitly, the node's step equals
  // the step under the constant force the integrator reports (applied_forces): the two contact
  // problems have the same solution. Checked on an impact (the node falls onto the floor within
  // the step) and in free flight, with a non-symmetric E (a smooth side with gyroscopic or
  // aerodynamic terms is not symmetric).
  const double h = 1e-3;
  Eigen::Matrix3d E;
  E << -2e5, 1e4, 0, -3e3, -1e5, 2e3, 0, 5e3, -4e5;
  for (double vz : {-1.5, 0.5}) {
    SCOPED_TRACE(vz);
    const ContactScene model = NodeModel(R"(contacts { obstacle: "floor" restitution: 0.6 })",
                                         {"model.contact_nodes[0].position=[0.1, 0.05, 0.0004]",
                                          "model.contact_nodes[0].velocity=[0.3, -0.2, " + std::to_string(vz) + "]"});
    MoreauJean tied(model, model.settings, 0.0);
    const Eigen::Vector3d reference(0.1003, 0.0498, -0.0002);
    tied.SetExternalForces(Eigen::Vector3d(1, -2, -20));
    tied.SetInterfaceStiffness(Eigen::Map<const Eigen::Matrix<double, 9, 1>>(Eigen::Matrix3d(E.transpose()).data()),
                               reference);
    tied.Step(0.0, h);
    const Eigen::Vector3d applied = tied.applied_forces().head<3>();
    // The held force is the law at the end position.
    EXPECT_LE((applied - (Eigen::Vector3d(1, -2, -20) + E * (tied.positions().head<3>() - reference))).norm(),
              1e-9 * applied.norm());
    MoreauJean plain(model, model.settings, 0.0);
    plain.SetExternalForces(applied);
    plain.Step(0.0, h);
    EXPECT_LE((plain.positions() - tied.positions()).lpNorm<Eigen::Infinity>(), 1e-14);
    EXPECT_LE((plain.velocities() - tied.velocities()).lpNorm<Eigen::Infinity>(), 1e-11);
    EXPECT_NEAR(plain.impulses()(0), tied.impulses()(0), 1e-12);
    if (vz < 0) {
      EXPECT_GT(tied.impulses()(0), 0.0);  // (the impact happened)
    }
  }
}

}  // namespace
}  // namespace cosim::nonsmooth
