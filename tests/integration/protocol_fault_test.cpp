// smooth_solver as coordinator against a contact peer that misbehaves on the wire: this test
// binds the contact process's endpoint itself and answers the coordinator's Hello with a
// message of another protocol version, or with bytes that are not a message. The coordinator
// must refuse either at the handshake with exit code 2 and a message naming the peer and what
// came, without a crash and without waiting out its timeout, and keep its outputs.
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <exception>
#include <functional>
#include <string>
#include <thread>
#include <zmq.hpp>

#include "coupling.pb.h"
#include "interface/coupling/channel.h"
#include "tests/integration/launch.h"

namespace {

using namespace cosim::test;

struct Outcome {
  int code = -1;
  double seconds = 0.0;
  std::string output;
};

// smooth_solver on tied_drop.pbtxt connecting to `endpoint`, while `answer` plays the contact
// process on a bound DEALER socket: it gets the coordinator's first message (the Hello) and
// returns the bytes to send back.
Outcome AgainstFakePeer(const std::string& name, const std::function<std::string(const std::string&)>& answer,
                        const std::string& extra = "") {
  const fs::path out = TempDir("fault_" + name);
  const std::string endpoint = "ipc://" + (TestRoot() / ("fault_" + name + ".ipc")).string();
  zmq::context_t context;
  zmq::socket_t peer(context, zmq::socket_type::dealer);
  peer.set(zmq::sockopt::linger, 0);
  peer.set(zmq::sockopt::rcvtimeo, 10000);
  peer.bind(endpoint);
  Outcome outcome;
  const auto t0 = std::chrono::steady_clock::now();
  std::thread coordinator([&] {
    const fs::path log = out / "stderr.txt";
    const std::string command = std::string(COSIM_BIN_DIR) + "/smooth_solver " + std::string(COSIM_SOURCE_DIR) +
                                "/scenarios/tied_drop.pbtxt --out " + (out / "run").string() +
                                " --set coupling.processes[0].endpoint='\"" + endpoint +
                                "\"' --set coupling.timeout=20 " + extra + " > " + log.string() + " 2>&1";
    const int status = std::system(command.c_str());
    outcome.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    outcome.output = Slurp(log);
  });
  zmq::message_t hello;
  bool got = peer.recv(hello).has_value();
  cosim::coupling::Envelope first;
  while (got && first.ParseFromArray(hello.data(), static_cast<int>(hello.size())) && first.has_heartbeat()) {
    got = peer.recv(hello).has_value();  // the coordinator's heartbeats, if it took its time
  }
  if (got) {
    const std::string reply = answer(hello.to_string());
    peer.send(zmq::buffer(reply), zmq::send_flags::none);
  }
  coordinator.join();
  outcome.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_TRUE(got) << "the coordinator never said Hello";
  EXPECT_TRUE(fs::exists(out / "run" / "summary.json"));
  return outcome;
}

TEST(ProtocolFaults, WrongVersionPeerIsRefusedAtHandshake) {
  const Outcome o = AgainstFakePeer("version", [](const std::string& hello_bytes) {
    cosim::coupling::Envelope hello;
    EXPECT_TRUE(hello.ParseFromString(hello_bytes));
    EXPECT_TRUE(hello.has_hello());
    EXPECT_EQ(hello.protocol_version(), static_cast<unsigned>(cosim::coupling::PROTOCOL_VERSION_CURRENT));
    cosim::coupling::Envelope welcome;
    welcome.set_protocol_version(1);  // an old contact process
    welcome.set_sender("contacts");
    welcome.set_step(-1);
    welcome.mutable_welcome()->set_process_name("contacts");
    return welcome.SerializeAsString();
  });
  EXPECT_EQ(o.code, 2) << o.output;
  EXPECT_NE(o.output.find("'contacts' speaks protocol version 1"), std::string::npos) << o.output;
  EXPECT_LT(o.seconds, 10.0);  // refused at once, not after the 20 s timeout
}

// A contact process's Welcome, from fields a test sets.
std::string WelcomeBytes(const std::string& process, const std::vector<std::string>& nodes) {
  cosim::coupling::Envelope welcome;
  welcome.set_protocol_version(cosim::coupling::PROTOCOL_VERSION_CURRENT);
  welcome.set_sender(process);
  welcome.set_step(-1);
  welcome.mutable_welcome()->set_process_name(process);
  for (const auto& node : nodes) welcome.mutable_welcome()->add_interface_nodes(node);
  return welcome.SerializeAsString();
}

TEST(ProtocolFaults, AWelcomeNamingOtherNodesIsRefused) {
  // Only the count was compared, so a contact process with a node-order bug
  // (or another scene's nodes) was coupled to the wrong nodes and the run ended "ok". The
  // Hello asked for "node"; this Welcome names "other".
  const Outcome o =
      AgainstFakePeer("welcome_nodes", [](const std::string&) { return WelcomeBytes("contacts", {"other"}); });
  EXPECT_EQ(o.code, 2) << o.output;
  EXPECT_NE(o.output.find("Welcome.interface_nodes[0] from 'contacts' is 'other'; the Hello asked for 'node' there"),
            std::string::npos)
      << o.output;
}

TEST(ProtocolFaults, AWelcomeFromAProcessOfAnotherNameIsRefused) {
  // The process that answers must be the one the Hello addressed.
  const Outcome o = AgainstFakePeer("welcome_name", [](const std::string&) { return WelcomeBytes("stops", {"node"}); });
  EXPECT_EQ(o.code, 2) << o.output;
  EXPECT_NE(o.output.find("the Welcome from the process addressed as 'contacts' names itself 'stops'"),
            std::string::npos)
      << o.output;
}

TEST(ProtocolFaults, SilentPeerEndsTheRunWithinTheTimeout) {
  // A contact process that welcomes the coordinator and then says nothing (it hung, or died on
  // another machine where no launcher watches it): the coordinator gives up after
  // coupling.timeout (here 2 s) with exit code 4, naming the peer and what it waited for.
  const Outcome o = AgainstFakePeer(
      "silent",
      [](const std::string&) {
        cosim::coupling::Envelope welcome;
        welcome.set_protocol_version(cosim::coupling::PROTOCOL_VERSION_CURRENT);
        welcome.set_sender("contacts");
        welcome.set_step(-1);
        welcome.mutable_welcome()->set_process_name("contacts");
        welcome.mutable_welcome()->add_interface_nodes("node");
        return welcome.SerializeAsString();
      },
      "--set coupling.timeout=2");
  EXPECT_EQ(o.code, 4) << o.output;
  EXPECT_NE(o.output.find("no message from 'contacts'"), std::string::npos) << o.output;
  EXPECT_GT(o.seconds, 1.9);
  EXPECT_LT(o.seconds, 8.0);
}

TEST(ProtocolFaults, MalformedMessageIsRefusedWithoutACrash) {
  const Outcome o =
      AgainstFakePeer("malformed", [](const std::string&) { return std::string("\xff\xff\xff not protobuf", 17); });
  EXPECT_EQ(o.code, 2) << o.output;
  EXPECT_NE(o.output.find("malformed message"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("'contacts'"), std::string::npos) << o.output;
  EXPECT_LT(o.seconds, 10.0);
}

}  // namespace

namespace {

TEST(ProtocolFaults, AContactProcessRefusingItsPartStopsTheRunAtOnce) {
  // The second contact process is penalty_solver without its stiffness: it refuses the scenario
  // (exit 2) while the coordinator waits for it. The launcher stops the coordinator (its outputs
  // kept) and the run exits 2 naming the field, in seconds rather than after the 10 s coupling
  // timeout. The run's summary (the coordinator's folder) says 2 and the contact process's
  // reason, not "terminated by a signal while waiting for Welcome" with exit 4.
  const fs::path out = TempDir("contact_refuses");
  const auto t0 = std::chrono::steady_clock::now();
  const Result r = Launch(std::string(COSIM_SOURCE_DIR) + "/tests/data/two_pendulums.pbtxt --out " + out.string() +
                          " --set coupling.processes[1].program=penalty_solver");
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("numerics.penalty.stiffness"), std::string::npos) << r.output;
  EXPECT_LT(seconds, 8.0);
  const cosim::run::RunSummary smooth = ReadSummary(out);
  EXPECT_EQ(smooth.status(), "failed");
  EXPECT_EQ(smooth.exit_code(), 2);
  EXPECT_NE(smooth.reason().find("contact process 'stops2' (penalty_solver) failed with exit code 2"),
            std::string::npos)
      << smooth.reason();
  EXPECT_NE(smooth.reason().find("numerics.penalty.stiffness"), std::string::npos) << smooth.reason();
}

}  // namespace

namespace {

TEST(ProtocolFaults, ABusyPeerKeepsTheCoordinatorWaitingThroughItsHeartbeats) {
  // docs/protocol.md promises heartbeats from a side busy for longer than the timeout; nothing
  // sent them, and a contact step longer than coupling.timeout ended the run as a dead peer.
  // Here the contact process (a Channel in this test) takes 3 timeouts to answer the Hello;
  // the coordinator waits (its heartbeat thread and ours keep both sides alive), sends its
  // first StepBegin, and ends with the exit code the peer then reports (3) and its reason.
  const fs::path out = TempDir("busy_peer");
  const std::string endpoint = "ipc://" + (TestRoot() / "busy_peer.ipc").string();
  zmq::context_t context;
  cosim::interface::Channel peer(&context, {endpoint, true, "contacts", "smooth_solver", 1.0, 0.1});
  const auto t0 = std::chrono::steady_clock::now();
  int code = -1;
  std::thread coordinator([&] {
    const std::string command = std::string(COSIM_BIN_DIR) + "/smooth_solver " + std::string(COSIM_SOURCE_DIR) +
                                "/scenarios/tied_drop.pbtxt --out " + (out / "run").string() +
                                " --set coupling.processes[0].endpoint='\"" + endpoint +
                                "\"' --set coupling.timeout=1 > " + (out / "stderr.txt").string() + " 2>&1";
    const int status = std::system(command.c_str());
    code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  });
  const auto& hello = peer.Receive(cosim::coupling::Envelope::kHello, -1, -1).hello();
  std::vector<std::string> nodes(hello.interface_nodes().begin(), hello.interface_nodes().end());
  std::this_thread::sleep_for(std::chrono::seconds(3));  // busy: three timeouts
  auto* welcome = peer.Outgoing(-1, 0).mutable_welcome();
  welcome->set_process_name("contacts");  // (the process the Hello addressed: the coordinator checks)
  for (const auto& n : nodes) welcome->add_interface_nodes(n);
  peer.Send();
  std::this_thread::sleep_for(std::chrono::seconds(2));  // the coordinator waits for Kinematics meanwhile
  const auto& begin = peer.Receive(cosim::coupling::Envelope::kStepBegin, 0, 0);
  EXPECT_TRUE(begin.has_step_begin());
  auto* stop = peer.Outgoing(0, 0).mutable_shutdown();
  stop->set_exit_code(3);
  stop->set_reason("the test's contact step failed");
  peer.Send();
  coordinator.join();
  EXPECT_GT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 5.0);
  EXPECT_EQ(code, 3) << Slurp(out / "stderr.txt");
  const cosim::run::RunSummary s = ReadSummary(out / "run");
  EXPECT_EQ(s.exit_code(), 3);
  EXPECT_NE(s.reason().find("the test's contact step failed"), std::string::npos) << s.reason();
}

}  // namespace

namespace {

// smooth_solver on `scenario` (with the extra `--set` arguments `sets`) coupled to a contact
// process `process` that this test plays on a Channel it binds: it answers the Hello with a
// Welcome for the coordinator's nodes, then `play` drives the exchange (any exception there
// fails the test, and the coordinator is still waited for). Returns smooth_solver's exit code;
// its outputs are in TestRoot()/name/run, its stderr in TestRoot()/name/stderr.txt.
int AgainstPlayedPeer(const std::string& name, const std::string& scenario, const std::string& process,
                      const std::string& sets, const std::function<void(cosim::interface::Channel&)>& play) {
  const fs::path out = TempDir(name);
  const std::string endpoint = "ipc://" + (TestRoot() / (name + ".ipc")).string();
  zmq::context_t context;
  cosim::interface::Channel peer(&context, {endpoint, true, process, "smooth_solver", 10.0, 0.5});
  int code = -1;
  std::thread coordinator([&] {
    const std::string command = std::string(COSIM_BIN_DIR) + "/smooth_solver " + std::string(COSIM_SOURCE_DIR) + "/" +
                                scenario + " --out " + (out / "run").string() +
                                " --set coupling.processes[0].endpoint='\"" + endpoint + "\"' " + sets + " > " +
                                (out / "stderr.txt").string() + " 2>&1";
    const int status = std::system(command.c_str());
    code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  });
  try {
    const auto& hello = peer.Receive(cosim::coupling::Envelope::kHello, -1, -1).hello();
    std::vector<std::string> nodes(hello.interface_nodes().begin(), hello.interface_nodes().end());
    const std::string addressed = hello.process_name();
    auto* welcome = peer.Outgoing(-1, 0).mutable_welcome();
    welcome->set_process_name(addressed);  // (the process the Hello addressed: the coordinator checks)
    for (const auto& n : nodes) welcome->add_interface_nodes(n);
    peer.Send();
    play(peer);
  } catch (const std::exception& e) {
    ADD_FAILURE() << "the peer's exchange ended: " << e.what();
  }
  coordinator.join();
  return code;
}

// Kinematics of one node at (x, 0, z) at rest, for step 0's `iteration`.
void SendNodeAt(cosim::interface::Channel& peer, int iteration, double x, double z, double vz = 0.0) {
  auto* k = peer.Outgoing(0, iteration).mutable_kinematics();
  for (double p : {x, 0.0, z}) k->add_position(p);
  for (double v : {0.0, 0.0, vz}) k->add_velocity(v);
  k->add_in_contact(0);
  peer.Send();
}

TEST(ProtocolFaults, NonFiniteKinematicsAreThePeersBadMessage) {
  // Coupling data were not checked for finiteness: a NaN position from a contact process gave
  // exit 3 blaming the step size, a NaN velocity was accepted with exit 0. Either is refused now
  // as the peer's bad message (exit 2), naming it.
  for (const bool position : {true, false}) {
    const std::string name = position ? "nan_position" : "nan_velocity";
    const int code = AgainstPlayedPeer(name, "scenarios/tied_drop.pbtxt", "contacts", "", [&](auto& peer) {
      peer.Receive(cosim::coupling::Envelope::kStepBegin, 0, 0);
      SendNodeAt(peer, 0, 0.0, position ? std::nan("") : 0.5, position ? 0.0 : std::nan(""));
    });
    EXPECT_EQ(code, 2) << Slurp(TestRoot() / name / "stderr.txt");
    const cosim::run::RunSummary s = ReadSummary(TestRoot() / name / "run");
    EXPECT_NE(s.reason().find("Kinematics from 'contacts' of step 0 has a non-finite value at index 2"),
              std::string::npos)
        << s.reason();
  }
}

TEST(ProtocolFaults, KinematicsTheSmoothSideCannotSolveAreBackTrackedFrom) {
  // A relaxation's update can send the peers reactions whose answer the smooth side cannot
  // solve (the Puma gust's lift-off: IQN-ILS's extrapolated secants moved a node 32 m and CGα
  // diverged, which ended the run with exit 3). Here a peer answers the second iteration of the
  // pendulum's only step with its node 1e200 m away: the tie's force overflows and CGα fails.
  // The coordinator must take a plain relaxed update from the first iteration instead, and the
  // step then converges on the node held where it was: exit 0, one back-track counted, its
  // iteration logged without an answer.
  int reactions = 0;
  const int code = AgainstPlayedPeer(
      "backtrack", "scenarios/pendulum_stop.pbtxt", "stops", "--set numerics.end_time=0.0005", [&](auto& peer) {
        peer.Receive(cosim::coupling::Envelope::kStepBegin, 0, 0);
        SendNodeAt(peer, 0, 1.0, 0.0);  // the tip node rests at (1, 0, 0)
        for (;;) {
          const cosim::coupling::Envelope& e = peer.ReceiveAny();
          if (e.has_reactions()) {
            ++reactions;
            SendNodeAt(peer, e.iteration(), e.iteration() == 1 ? 1e200 : 1.0, 0.0);
          } else if (e.has_step_end()) {
            EXPECT_TRUE(e.step_end().accepted());
            peer.Outgoing(e.step(), e.iteration()).mutable_step_end()->set_accepted(true);
            peer.Send();
          } else if (e.has_shutdown()) {
            peer.Outgoing(-1, 0).mutable_shutdown()->set_exit_code(0);
            peer.Send();
            return;
          } else {
            ADD_FAILURE() << "unexpected message " << e.DebugString();
            return;
          }
        }
      });
  const fs::path out = TestRoot() / "backtrack";
  ASSERT_EQ(code, 0) << Slurp(out / "stderr.txt");
  EXPECT_GE(reactions, 2);
  const cosim::run::RunSummary s = ReadSummary(out / "run");
  EXPECT_EQ(s.counters().at("coupling_backtracks"), 1.0);
  const std::string log = Slurp(out / "run" / "coupling.csv");
  EXPECT_NE(log.find("\n0,1,inf,"), std::string::npos) << log;  // step 0, iteration 1: no answer
}

}  // namespace
