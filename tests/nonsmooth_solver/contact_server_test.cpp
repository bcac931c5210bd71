// The contact process's side of the coupling protocol (nonsmooth_solver/coupling/
// contact_server), driven over inproc by a test coordinator: the handshake, tentative steps
// that start again from the step's start at every iteration, accept and reject, and refusals.
#include "nonsmooth_solver/coupling/contact_server.h"

#include <gtest/gtest.h>

#include <cmath>
#include <exception>
#include <functional>
#include <limits>
#include <thread>
#include <zmq.hpp>

#include "interface/base/errors.h"
#include "interface/scenario/checks.h"
#include "nonsmooth_solver/simulation/contact_simulation.h"

namespace cosim::nonsmooth {
namespace {

using coupling::Envelope;

// The bouncing ball of scenarios/bouncing_ball.pbtxt: 1 kg at z = 1 m above the ground plane.
const interface::ScenarioFile& Ball() {
  static const interface::ScenarioFile file =
      interface::ScenarioFile::Load(std::string(COSIM_SOURCE_DIR) + "/scenarios/bouncing_ball.pbtxt", {});
  return file;
}

// Runs a ContactServer on its own thread; the test thread is the coordinator.
struct Harness {
  zmq::context_t context;
  ContactSimulation simulation{Ball()};
  interface::Channel contact {
    &context, { "inproc://server", true, "contacts", "smooth", 2.0, 0.5 }
  };
  interface::Channel smooth {
    &context, { "inproc://server", false, "smooth", "contacts", 2.0, 0.5 }
  };
  ContactServer server{&simulation, &contact, "bouncing_ball"};
  std::exception_ptr failure;
  std::thread thread{[this] {
    try {
      server.Run();
    } catch (...) {
      failure = std::current_exception();
    }
  }};
  ~Harness() {
    if (thread.joinable()) thread.join();
  }
  // The Hello for `node`, changed by `edit` before it is sent.
  void Hello(const std::string& node, const std::function<void(coupling::Hello*)>& edit = {}) {
    auto* hello = smooth.Outgoing(-1, 0).mutable_hello();
    hello->set_scenario_name("bouncing_ball");
    hello->add_interface_nodes(node);
    hello->set_step(0.005);
    if (edit) edit(hello);
    smooth.Send();
  }
  // A StepBegin without a predictor, and the Kinematics the process answers it with.
  const coupling::Kinematics& Begin(int64_t step, double t, double dt) {
    auto* begin = smooth.Outgoing(step, 0).mutable_step_begin();
    begin->set_time(t);
    begin->set_step(dt);
    smooth.Send();
    return smooth.Receive(Envelope::kKinematics, step, 0).kinematics();
  }
  // The refusal the server ended with (empty if none).
  std::string Refusal() {
    thread.join();
    if (!failure) return "";
    try {
      std::rethrow_exception(failure);
    } catch (const InputError& e) {
      return e.what();
    } catch (const std::exception& e) {
      return std::string("not an input error: ") + e.what();
    }
  }
  const coupling::Kinematics& Iterate(int64_t step, int iteration, double fz) {
    auto* r = smooth.Outgoing(step, iteration).mutable_reactions();
    for (double f : {0.0, 0.0, fz}) r->add_force(f);
    smooth.Send();
    return smooth.Receive(Envelope::kKinematics, step, iteration).kinematics();
  }
  void Finish() {
    smooth.Outgoing(-1, 0).mutable_shutdown();
    smooth.Send();
    smooth.Receive(Envelope::kShutdown, -1, -1);
    thread.join();
    if (failure) std::rethrow_exception(failure);
  }
};

TEST(ContactServer, IterationsRestartFromTheStepStartAndOnlyAcceptedStepsCount) {
  // A reaction of +m g holds the ball still; without it the ball falls by ½ g h² in the step
  // (θ = ½: exact for constant gravity). Each Reactions message recomputes the same step from
  // its start, whatever came before in the step; a rejected step is undone.
  Harness h;
  h.Hello("ball");
  EXPECT_EQ(h.smooth.Receive(Envelope::kWelcome, -1, -1).welcome().interface_nodes(0), "ball");
  const double g = 9.81, dt = 0.005;
  for (int64_t step = 0; step < 2; ++step) {
    h.Begin(step, static_cast<double>(step) * dt, dt);  // predictor: the last accepted reactions
    const coupling::Kinematics falling = h.Iterate(step, 1, 0.0);
    EXPECT_NEAR(falling.position(2), 1.0 - 0.5 * g * dt * dt, 1e-14);
    EXPECT_NEAR(falling.velocity(2), -g * dt, 1e-14);
    const coupling::Kinematics held = h.Iterate(step, 2, g);
    EXPECT_NEAR(held.position(2), 1.0, 1e-14);
    EXPECT_NEAR(held.velocity(2), 0.0, 1e-14);
    EXPECT_EQ(held.in_contact(0), 0);
    auto* end = h.smooth.Outgoing(step, 2).mutable_step_end();
    end->set_accepted(step == 0);  // accept the first step, reject the second
    h.smooth.Send();
    EXPECT_EQ(h.smooth.Receive(Envelope::kStepEnd, step, 2).step_end().accepted(), step == 0);
  }
  h.Finish();
  EXPECT_EQ(h.server.accepted_steps(), 1);
  EXPECT_EQ(h.server.tentative_steps(), 6);
  EXPECT_NEAR(h.simulation.integrator().positions()(2), 1.0, 1e-14);  // the rejected step is undone
  EXPECT_NEAR(h.simulation.integrator().time(), dt, 1e-15);
}

TEST(ContactServer, TheNextStepBeginAcceptsAStepAndShutdownSaysWhichWasTheLast) {
  // Protocol 3: an accepted step gets no StepEnd; the StepBegin of the next step accepts it, and
  // Shutdown.last_accepted_step accepts a step waiting when the run ends (or not, when the
  // coordinator had not accepted it). The free ball's Kinematics carry the interface
  // Jacobians: the force held (the predictor's, no stiffness sent) and the sensitivities of a
  // free 1 kg point, ∂v/∂f = h/m and ∂q/∂f = hθ h/m on the diagonal.
  for (const int64_t last : {int64_t{2}, int64_t{1}}) {
    SCOPED_TRACE(last);
    Harness h;
    h.Hello("ball");
    EXPECT_TRUE(h.smooth.Receive(Envelope::kWelcome, -1, -1).welcome().interface_jacobians());
    const double g = 9.81, dt = 0.005;
    for (int64_t step = 0; step < 3; ++step) {
      auto* begin = h.smooth.Outgoing(step, 0).mutable_step_begin();
      begin->set_time(static_cast<double>(step) * dt);
      begin->set_step(dt);
      for (double f : {0.0, 0.0, g}) begin->mutable_predictor()->add_force(f);  // held still
      h.smooth.Send();
      const coupling::Kinematics& k = h.smooth.Receive(Envelope::kKinematics, step, 0).kinematics();
      EXPECT_NEAR(k.position(2), 1.0, 1e-14);
      ASSERT_EQ(k.applied_force_size(), 3);
      EXPECT_EQ(k.applied_force(2), g);
      ASSERT_EQ(k.velocity_sensitivity_size(), 9);
      ASSERT_EQ(k.position_sensitivity_size(), 9);
      EXPECT_NEAR(k.velocity_sensitivity(0), dt, 1e-15);
      EXPECT_NEAR(k.position_sensitivity(8), 0.5 * dt * dt, 1e-15);
      EXPECT_EQ(k.velocity_sensitivity(1), 0.0);
      EXPECT_EQ(h.server.accepted_steps(), step);  // the StepBegin accepted the step before
    }
    auto* stop = h.smooth.Outgoing(-1, 0).mutable_shutdown();
    stop->set_last_accepted_step(last);
    h.smooth.Send();
    h.smooth.Receive(Envelope::kShutdown, -1, -1);
    h.thread.join();
    if (h.failure) std::rethrow_exception(h.failure);
    EXPECT_EQ(h.server.accepted_steps(), last + 1);
  }
}

TEST(ContactServer, TheCoordinatorsStiffnessIsHeldAsAForceLawAtTheNodesEndPosition) {
  // Reactions.stiffness and .position (the smooth side linearised): the ball is held by
  // f = f̂ + E (z_end − ẑ) with E = −1e4 N/m, f̂ = m g, ẑ = 0.99 m: a spring pulling it down
  // towards 0.99 m over the step. The force it reports held is the law at its end position.
  Harness h;
  h.Hello("ball");
  h.smooth.Receive(Envelope::kWelcome, -1, -1);
  const double g = 9.81, dt = 0.005, E = -1e4;
  auto* begin = h.smooth.Outgoing(0, 0).mutable_step_begin();
  begin->set_time(0.0);
  begin->set_step(dt);
  for (double f : {0.0, 0.0, g}) begin->mutable_predictor()->add_force(f);
  for (int i = 0; i < 9; ++i) begin->mutable_predictor()->add_stiffness(i == 8 ? E : 0.0);
  for (double x : {0.0, 0.0, 0.99}) begin->mutable_predictor()->add_position(x);
  h.smooth.Send();
  const coupling::Kinematics& k = h.smooth.Receive(Envelope::kKinematics, 0, 0).kinematics();
  const double z = k.position(2);
  EXPECT_LT(z, 1.0);  // pulled down
  EXPECT_NEAR(k.applied_force(2), g + E * (z - 0.99), 1e-9);
  // Implicitly: (m − h²θE) v = h (f̂ + E (z₀ − ẑ)) − h m g from rest, z = z₀ + hθ v.
  const double v = dt * (g + E * (1.0 - 0.99) - g) / (1.0 - dt * dt * 0.5 * E);
  EXPECT_NEAR(z, 1.0 + 0.5 * dt * v, 1e-12);
  h.Finish();
}

TEST(ContactServer, ARejectedStepIsRedoneWithAnotherLengthFromTheSameStart) {
  // The adaptive step's protocol: the coordinator rejects a step (StepEnd accepted = false) and
  // begins the same step again, shorter. The redone step starts from the rejected one's start
  // state, as if the rejected one had never been tried; each Kinematics says how long until the
  // ball could reach the ground at its present speed (gap / closing speed; +∞ while still).
  Harness h;
  h.Hello("ball");
  h.smooth.Receive(Envelope::kWelcome, -1, -1);
  const double g = 9.81, dt = 0.005;
  for (const double step : {dt, 0.5 * dt}) {
    const coupling::Kinematics& k = h.Begin(0, 0.0, step);
    EXPECT_NEAR(k.position(2), 1.0 - 0.5 * g * step * step, 1e-14);
    ASSERT_TRUE(k.has_time_to_contact());
    EXPECT_NEAR(k.time_to_contact(), (1.0 - 0.5 * g * step * step) / (g * step), 1e-9);
    auto* end = h.smooth.Outgoing(0, 0).mutable_step_end();
    end->set_accepted(step < dt);  // the long one rejected, the short one accepted
    h.smooth.Send();
    h.smooth.Receive(Envelope::kStepEnd, 0, 0);
  }
  h.Finish();
  EXPECT_EQ(h.server.accepted_steps(), 1);
  EXPECT_EQ(h.server.rejected_steps(), 1);
  EXPECT_NEAR(h.simulation.integrator().positions()(2), 1.0 - 0.5 * g * 0.25 * dt * dt, 1e-14);
  EXPECT_NEAR(h.simulation.integrator().velocities()(2), -g * 0.5 * dt, 1e-14);
  EXPECT_NEAR(h.simulation.integrator().time(), 0.5 * dt, 1e-15);
}

TEST(ContactServer, UnknownInterfaceNodeIsRefusedNamingIt) {
  Harness h;
  h.Hello("bal");
  h.thread.join();
  ASSERT_TRUE(h.failure);
  try {
    std::rethrow_exception(h.failure);
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("Hello.interface_nodes[0] from 'smooth' names contact node 'bal', which "
                                         "this process does not have; known: ball"),
              std::string::npos)
        << e.what();
  }
}

// A coordinator's invalid Hello was welcomed (an infinite step, a start time
// that is not a number, a node named twice, no node at all) and its text echoed whole. Each
// Hello below is played as it was sent and must be refused naming the field and the value.
std::string RefusalOfHello(const std::function<void(coupling::Hello*)>& edit) {
  Harness h;
  h.Hello("ball", edit);
  return h.Refusal();
}

TEST(ContactServer, AHelloWithAStepOrStartThatIsNotFiniteIsRefused) {
  EXPECT_NE(RefusalOfHello([](coupling::Hello* m) {
              m->set_step(std::numeric_limits<double>::infinity());
            }).find("Hello.step from 'smooth' is inf; expected a positive, finite step [s]"),
            std::string::npos);
  EXPECT_NE(RefusalOfHello([](coupling::Hello* m) {
              m->set_start_time(std::nan(""));
            }).find("Hello.start_time from 'smooth' is nan; expected a finite time [s]"),
            std::string::npos);
  EXPECT_NE(RefusalOfHello([](coupling::Hello* m) {
              m->set_start_time(-std::numeric_limits<double>::infinity());
            }).find("Hello.start_time from 'smooth' is -inf"),
            std::string::npos);
}

TEST(ContactServer, AHelloNamingANodeTwiceOrNoneIsRefused) {
  EXPECT_NE(RefusalOfHello([](coupling::Hello* m) {
              m->add_interface_nodes("ball");
            }).find("Hello.interface_nodes[1] from 'smooth' names contact node 'ball' a second time"),
            std::string::npos);
  EXPECT_NE(RefusalOfHello([](coupling::Hello* m) {
              m->clear_interface_nodes();
            }).find("Hello from 'smooth' names no interface node"),
            std::string::npos);
}

TEST(ContactServer, ASettledStartsNodePositionsMoveTheNodeOrAreRefused) {
  // A settled start's Hello puts each node where the smooth side's settle left it: the ball at
  // z = 0.4 m, moving up at 2 m/s, instead of the scenario's 1 m at rest; the first step starts
  // there (held by +m g: it moves by h v).
  {
    Harness h;
    h.Hello("ball", [](coupling::Hello* hello) {
      hello->set_settled(true);
      for (double x : {0.0, 0.0, 0.4}) hello->add_node_positions(x);
      for (double v : {0.0, 0.0, 2.0}) hello->add_node_velocities(v);
    });
    h.smooth.Receive(Envelope::kWelcome, -1, -1);
    h.Begin(0, 0.0, 0.005);
    const coupling::Kinematics held = h.Iterate(0, 1, 9.81);
    EXPECT_NEAR(held.position(2), 0.4 + 0.005 * 2.0, 1e-14);
    EXPECT_NEAR(held.velocity(2), 2.0, 1e-14);
    h.Finish();
  }
  // Not 3 per node, or not finite: refused naming the node and the value.
  EXPECT_NE(RefusalOfHello([](coupling::Hello* m) {
              m->add_node_positions(0.0);
              m->add_node_velocities(0.0);
            }).find("gives 1 node positions and 1 node velocities; expected 3 of each"),
            std::string::npos);
  EXPECT_NE(RefusalOfHello([](coupling::Hello* m) {
              for (double x : {0.0, std::nan(""), 0.4}) m->add_node_positions(x);
              for (int i = 0; i < 3; ++i) m->add_node_velocities(0.0);
            }).find("a non-finite start for node 'ball' (node_positions[1] = nan"),
            std::string::npos);
}

TEST(ContactServer, AFreeStartsNodeMustBeAtItsTiedPoint) {
  // Protocol 4: a free start's Hello gives the tied points' state; the node must start there (to
  // round-off), or its stiff tie would swing it about its point for the whole run. The ball is at
  // z = 1 m at rest: a point there is accepted (and the node starts exactly on it), one 1 mm
  // lower or moving at 1 m/s is refused naming the node and both states.
  const auto point = [](double z, double w) {
    return [z, w](coupling::Hello* hello) {
      for (double x : {0.0, 0.0, z}) hello->add_node_positions(x);
      for (double v : {0.0, 0.0, w}) hello->add_node_velocities(v);
    };
  };
  {
    Harness h;
    h.Hello("ball", point(1.0 + 1e-9, 0.0));
    h.smooth.Receive(Envelope::kWelcome, -1, -1);
    EXPECT_EQ(h.simulation.integrator().positions()(2), 1.0 + 1e-9);
    h.Finish();
  }
  std::string refusal = RefusalOfHello(point(0.999, 0.0));
  EXPECT_NE(refusal.find("contact node 'ball' is not at its tied point at the start: give it position "
                         "[0, 0, 0.999] m, velocity [0, 0, 0] m/s"),
            std::string::npos)
      << refusal;
  refusal = RefusalOfHello(point(1.0, 1.0));
  EXPECT_NE(refusal.find("position [0, 0, 1] m, velocity [0, 0, 1] m/s"), std::string::npos) << refusal;
}

TEST(ContactServer, APeersLongTextIsEchoedCut) {
  // A 20 MB scenario name made a 20 MB summary.json and log.txt: the refusal quotes 200 bytes
  // and says how long the name was.
  const std::string refusal =
      RefusalOfHello([](coupling::Hello* m) { m->set_scenario_name(std::string(20000000, 'x')); });
  EXPECT_NE(refusal.find("(20000000 bytes)"), std::string::npos);
  EXPECT_LT(refusal.size(), 1000u);
}

TEST(EchoedText, CutsAtACharacterBoundary) {
  // 199 ASCII bytes and then "é" (2 bytes, straddling the 200-byte limit): the cut falls before
  // it, never inside it, so the echoed text stays valid UTF-8.
  const std::string text = std::string(199, 'a') + "é" + std::string(50, 'b');
  EXPECT_EQ(interface::EchoedText(text), std::string(199, 'a') + "… (251 bytes)");
  EXPECT_EQ(interface::EchoedText("short"), "short");
}

TEST(ContactServer, AStepBeginAtATimeThatIsNotANumberIsRefused) {
  // StepBegin.time = NaN was answered (|NaN − t| > tol is false) and a whole
  // run ended "ok" with nan in the contact history.
  Harness h;
  h.Hello("ball");
  h.smooth.Receive(Envelope::kWelcome, -1, -1);
  auto* begin = h.smooth.Outgoing(0, 0).mutable_step_begin();
  begin->set_time(std::nan(""));
  begin->set_step(0.005);
  h.smooth.Send();
  const std::string refusal = h.Refusal();
  EXPECT_NE(refusal.find("StepBegin.time from 'smooth' is nan; expected a finite time [s]"), std::string::npos)
      << refusal;
}

TEST(ContactServer, ReactionsOfTheWrongSizeAreRefused) {
  Harness h;
  h.Hello("ball");
  h.smooth.Receive(Envelope::kWelcome, -1, -1);
  h.Begin(0, 0.0, 0.005);
  h.smooth.Outgoing(0, 1).mutable_reactions()->add_force(1.0);
  h.smooth.Send();
  h.thread.join();
  ASSERT_TRUE(h.failure);
  try {
    std::rethrow_exception(h.failure);
  } catch (const InputError& e) {
    EXPECT_NE(
        std::string(e.what()).find("Reactions.force from 'smooth' has 1 values; expected 3 per interface node, 3"),
        std::string::npos)
        << e.what();
  }
}

TEST(ContactServer, RestartedNodesMoveTheNodeAsTheStepIsAcceptedAndTheNextStepStartsThere) {
  // Protocol 4: after a restart at an impact the coordinator's StepBegin (or Shutdown) lists the
  // nodes it moved; the process makes that the accepted state before it begins the next step, so
  // a rejected try of that step comes back to it. The ball held still at z = 1 m is moved to
  // z = 1.2 m rising at 1 m/s; the next step, held by +m g, ends at 1.2 + h m with the same speed.
  for (const bool by_shutdown : {false, true}) {
    SCOPED_TRACE(by_shutdown ? "Shutdown" : "StepBegin");
    Harness h;
    h.Hello("ball");
    h.smooth.Receive(Envelope::kWelcome, -1, -1);
    const double g = 9.81, dt = 0.005;
    const auto move = [](coupling::RestartedNodes* r) {
      r->add_node(0);
      for (double x : {0.0, 0.0, 1.2}) r->add_position(x);
      for (double v : {0.0, 0.0, 1.0}) r->add_velocity(v);
    };
    auto* begin = h.smooth.Outgoing(0, 0).mutable_step_begin();
    begin->set_time(0.0);
    begin->set_step(dt);
    for (double f : {0.0, 0.0, g}) begin->mutable_predictor()->add_force(f);
    h.smooth.Send();
    h.smooth.Receive(Envelope::kKinematics, 0, 0);
    if (by_shutdown) {
      auto* stop = h.smooth.Outgoing(-1, 0).mutable_shutdown();
      stop->set_last_accepted_step(0);
      move(stop->mutable_restarted_nodes());
      h.smooth.Send();
      h.smooth.Receive(Envelope::kShutdown, -1, -1);
      h.thread.join();
      if (h.failure) std::rethrow_exception(h.failure);
      EXPECT_NEAR(h.simulation.integrator().positions()(2), 1.2, 1e-15);  // (its final state)
      EXPECT_NEAR(h.simulation.integrator().velocities()(2), 1.0, 1e-15);
      continue;
    }
    for (int attempt = 0; attempt < 2; ++attempt) {  // a rejected try starts from the moved node too
      auto* next = h.smooth.Outgoing(1, 0).mutable_step_begin();
      next->set_time(dt);
      next->set_step(dt);
      if (attempt == 0) move(next->mutable_restarted_nodes());
      for (double f : {0.0, 0.0, g}) next->mutable_predictor()->add_force(f);
      h.smooth.Send();
      const coupling::Kinematics& k = h.smooth.Receive(Envelope::kKinematics, 1, 0).kinematics();
      EXPECT_NEAR(k.position(2), 1.2 + dt, 1e-14);
      EXPECT_NEAR(k.velocity(2), 1.0, 1e-14);
      if (attempt == 0) {
        h.smooth.Outgoing(1, 0).mutable_step_end()->set_accepted(false);
        h.smooth.Send();
        h.smooth.Receive(Envelope::kStepEnd, 1, 0);
      }
    }
    h.Finish();
  }
}

// A StepBegin whose restarted_nodes do not fit: each refused naming the field and the value.
std::string RefusalOfRestartedNodes(bool accepting, const std::function<void(coupling::RestartedNodes*)>& edit) {
  Harness h;
  h.Hello("ball");
  h.smooth.Receive(Envelope::kWelcome, -1, -1);
  int64_t step = 0;
  if (accepting) {
    h.Begin(0, 0.0, 0.005);
    step = 1;
  }
  auto* begin = h.smooth.Outgoing(step, 0).mutable_step_begin();
  begin->set_time(0.005 * static_cast<double>(step));
  begin->set_step(0.005);
  edit(begin->mutable_restarted_nodes());
  h.smooth.Send();
  return h.Refusal();
}

TEST(ContactServer, RestartedNodesThatDoNotFitAreRefused) {
  const auto node = [](int k, double z) {
    return [k, z](coupling::RestartedNodes* r) {
      r->add_node(k);
      for (double x : {0.0, 0.0, z}) r->add_position(x);
      for (double v : {0.0, 0.0, 0.0}) r->add_velocity(v);
    };
  };
  std::string refusal = RefusalOfRestartedNodes(true, node(1, 1.0));
  EXPECT_NE(refusal.find("StepBegin.restarted_nodes.node[0] from 'smooth' is 1; expected the index of an interface "
                         "node of the Hello (0 to 0), each listed once"),
            std::string::npos)
      << refusal;
  refusal = RefusalOfRestartedNodes(true, [&](coupling::RestartedNodes* r) {
    node(0, 1.0)(r);
    node(0, 1.0)(r);
  });
  EXPECT_NE(refusal.find("node[1] from 'smooth' is 0"), std::string::npos) << refusal;
  refusal = RefusalOfRestartedNodes(true, node(0, std::nan("")));
  EXPECT_NE(refusal.find("moves node 0 to a non-finite state (position[2] = nan"), std::string::npos) << refusal;
  refusal = RefusalOfRestartedNodes(true, [&](coupling::RestartedNodes* r) {
    node(0, 1.0)(r);
    r->add_velocity(0.0);
  });
  EXPECT_NE(refusal.find("lists 1 nodes with 3 position and 4 velocity values; expected 3 of each"), std::string::npos)
      << refusal;
  refusal = RefusalOfRestartedNodes(false, node(0, 1.0));  // (the first step: it accepts none)
  EXPECT_NE(refusal.find("carries restarted_nodes but accepts no step"), std::string::npos) << refusal;
}

}  // namespace
}  // namespace cosim::nonsmooth
