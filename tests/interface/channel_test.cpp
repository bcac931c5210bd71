// The coupling protocol's transport (interface/coupling/channel): a round trip of the real
// messages over inproc and ipc, and the failures a coordinator must survive with a clear
// message — a silent peer (timeout, exit 4), a heartbeating but slow peer (not a failure), a
// malformed message, a wrong protocol version and an out-of-order message (exit 2).
#include "interface/coupling/channel.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <functional>
#include <string>
#include <thread>
#include <zmq.hpp>

#include "interface/base/errors.h"

namespace cosim::interface {
namespace {

using coupling::Envelope;

struct Pair {
  zmq::context_t context;
  Channel contact, smooth;
  explicit Pair(const std::string& endpoint, double timeout = 2.0)
      : contact(&context, {endpoint, true, "contact", "smooth", timeout, 0.05}),
        smooth(&context, {endpoint, false, "smooth", "contact", timeout, 0.05}) {}
};

void ExpectCode(ExitCode code, const std::function<void()>& f, const std::string& fragment) {
  try {
    f();
    ADD_FAILURE() << "no error; expected one containing '" << fragment << "'";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), code) << e.what();
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

void RoundTrip(Pair& p) {
  // Coordinator → contact: Reactions of step 4, iteration 2, with one moving-obstacle frame.
  auto* reactions = p.smooth.Outgoing(4, 2).mutable_reactions();
  for (double v : {1.0, -2.0, 3.5}) reactions->add_force(v);
  reactions->add_obstacle_frames()->add_position(0.25);
  p.smooth.Send();
  const Envelope& got = p.contact.Receive(Envelope::kReactions, 4, 2);
  ASSERT_EQ(got.reactions().force_size(), 3);
  EXPECT_EQ(got.reactions().force(1), -2.0);
  EXPECT_EQ(got.sender(), "smooth");
  EXPECT_EQ(got.reactions().obstacle_frames(0).position(0), 0.25);
  // And back: Kinematics.
  auto* k = p.contact.Outgoing(4, 2).mutable_kinematics();
  for (double v : {0.1, 0.2, 0.3}) k->add_position(v);
  for (double v : {-1.0, 0.0, 1.0}) k->add_velocity(v);
  p.contact.Send();
  const Envelope& back = p.smooth.Receive(Envelope::kKinematics, 4, 2);
  EXPECT_EQ(back.kinematics().velocity(0), -1.0);
  EXPECT_EQ(back.sender(), "contact");
}

TEST(Channel, MessagesRoundTripOverInprocAndIpc) {
  Pair inproc("inproc://round_trip");
  RoundTrip(inproc);
  const std::string ipc = "ipc:///tmp/cosim_channel_test_" + std::to_string(getpid());
  Pair over_ipc(ipc);
  RoundTrip(over_ipc);
}

TEST(Channel, SilentPeerEndsTheWaitWithExitCodeFourNamingIt) {
  // Nobody answers: after `timeout` the coordinator gives up with a PeerError that names the
  // peer, the endpoint and what it waited for — within the timeout plus polling slack.
  // (A bare socket: a Channel would send heartbeats from its own thread.)
  zmq::context_t context;
  zmq::socket_t silent(context, zmq::socket_type::dealer);
  silent.bind("inproc://silent");
  Channel smooth(&context, {"inproc://silent", false, "smooth", "contact", 0.3, 0.05});
  const auto t0 = std::chrono::steady_clock::now();
  ExpectCode(
      ExitCode::kPeerFailure, [&] { smooth.Receive(Envelope::kKinematics, 7, 0); },
      "no message from 'contact' (inproc://silent) for 0.3 s while waiting for Kinematics of step 7");
  const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_GT(waited, 0.29);
  EXPECT_LT(waited, 0.6);
}

TEST(Channel, AProcessStoppedBetweenTwoReceivesDoesNotCountThatTimeAsThePeersSilence) {
  // A receive slice that overran (its process stopped by ^Z for longer than the timeout) moved
  // the deadline, but a stop that fell between two slices (after the deadline was set, or
  // after one slice ended and before the next began) was counted as the peer's silence: on
  // resume the wait ended with exit 4 at once. Replayed with a clock that jumps 3 s at every
  // reading, as a process stopped for 3 s between each two of its readings sees it (timeout
  // 1 s): the reply sent 0.3 s later is received. (A bare socket as the peer: a Channel's
  // heartbeats would reset the wait.)
  zmq::context_t context;
  zmq::socket_t peer(context, zmq::socket_type::dealer);
  peer.bind("inproc://stopped_between");
  const auto start = std::chrono::steady_clock::now();
  int readings = 0;
  ChannelOptions options{"inproc://stopped_between", false, "smooth", "contact", 1.0, 0.05};
  options.clock = [&] {
    ++readings;
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() + 3.0 * readings;
  };
  Channel smooth(&context, options);
  std::thread reply([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    Envelope kinematics;
    kinematics.set_protocol_version(coupling::PROTOCOL_VERSION_CURRENT);
    kinematics.set_sender("contact");
    kinematics.set_step(7);
    kinematics.mutable_kinematics()->add_position(0.5);
    const std::string bytes = kinematics.SerializeAsString();
    peer.send(zmq::buffer(bytes), zmq::send_flags::none);
  });
  try {
    const Envelope& got = smooth.Receive(Envelope::kKinematics, 7, 0);
    EXPECT_EQ(got.kinematics().position(0), 0.5);
  } catch (const Error& e) {
    ADD_FAILURE() << e.what();
  }
  reply.join();
  EXPECT_GE(readings, 3);  // the clock was read between receives, and jumped there
}

TEST(Channel, HeartbeatsKeepASlowPeerAlive) {
  // The contact side is busy for three timeouts but sends heartbeats meanwhile: the wait goes
  // on, and the reply arrives.
  Pair p("inproc://slow", 0.2);
  std::thread busy([&] {
    // Busy: no call into the channel at all; its own thread sends the heartbeats.
    std::this_thread::sleep_for(std::chrono::milliseconds(600));
    p.contact.Outgoing(1, 0).mutable_kinematics();
    p.contact.Send();
  });
  EXPECT_NO_THROW(p.smooth.Receive(Envelope::kKinematics, 1, 0));
  busy.join();
  EXPECT_GE(p.contact.heartbeats_sent(), 5);  // every 0.05 s for 0.6 s, give or take the thread's wake-ups
}

TEST(Channel, MalformedWrongVersionAndOutOfOrderMessagesAreRefused) {
  Pair p("inproc://refusals");
  // Bytes that are not an Envelope (an invalid wire type).
  const std::string junk = "\xff\xff\xff\xff garbage";
  p.contact.socket().send(zmq::buffer(junk), zmq::send_flags::none);
  ExpectCode(
      ExitCode::kBadInput, [&] { p.smooth.Receive(Envelope::kWelcome, -1, 0); },
      "a malformed message (12 bytes) from 'contact' while waiting for Welcome");
  // A peer of another protocol version.
  Envelope old_version;
  old_version.set_protocol_version(7);
  old_version.mutable_welcome();
  p.contact.socket().send(zmq::buffer(old_version.SerializeAsString()), zmq::send_flags::none);
  ExpectCode(
      ExitCode::kBadInput, [&] { p.smooth.Receive(Envelope::kWelcome, -1, 0); },
      "'contact' speaks protocol version 7, this program speaks version " +
          std::to_string(cosim::coupling::PROTOCOL_VERSION_CURRENT));
  // The right message for the wrong iteration, then the wrong message.
  p.contact.Outgoing(3, 1).mutable_kinematics();
  p.contact.Send();
  ExpectCode(
      ExitCode::kBadInput, [&] { p.smooth.Receive(Envelope::kKinematics, 3, 2); },
      "got Kinematics of step 3, iteration 1, expected Kinematics of step 3, iteration 2");
  p.contact.Outgoing(3, 2).mutable_step_end();
  p.contact.Send();
  ExpectCode(
      ExitCode::kBadInput, [&] { p.smooth.Receive(Envelope::kKinematics, 3, 2); },
      "got StepEnd of step 3, iteration 2, expected Kinematics");
  // A peer that reports its own failure.
  auto* stop = p.contact.Outgoing(3, 2).mutable_shutdown();
  stop->set_exit_code(3);
  stop->set_reason("LCP failed at t = 0.25 s");
  p.contact.Send();
  // A peer that reports its own numerical failure: this side ends with the same code (3), not
  // as a peer failure (4), and passes its reason on.
  ExpectCode(
      ExitCode::kNumericalFailure, [&] { p.smooth.Receive(Envelope::kKinematics, 3, 2); },
      "'contact' stopped (exit code 3) while this side waited for Kinematics of step 3, iteration 2: LCP failed");
}

TEST(Channel, ASendToAGonePeerGivesUpWithinTheTimeout) {
  // A contact process whose coordinator is gone (none connected): its send used to block for
  // ever. It ends with a PeerError after `timeout`.
  zmq::context_t context;
  Channel contact(&context, {"inproc://nobody", true, "contact", "smooth", 0.3, 0.05});
  contact.Outgoing(1, 0).mutable_kinematics();
  const auto t0 = std::chrono::steady_clock::now();
  ExpectCode(
      ExitCode::kPeerFailure, [&] { contact.Send(); },
      "could not send Kinematics to 'smooth' (inproc://nobody) for 0.3 s: the peer is gone");
  const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_GT(waited, 0.25);
  EXPECT_LT(waited, 1.0);
}

// Two CURVE key pairs, as the launcher makes them for a run.
CurveKeys RunKeys() {
  char server_public[41], server_secret[41], client_public[41], client_secret[41];
  EXPECT_EQ(zmq_curve_keypair(server_public, server_secret), 0);
  EXPECT_EQ(zmq_curve_keypair(client_public, client_secret), 0);
  return CurveKeys{server_public, server_secret, client_public, client_secret};
}

TEST(Channel, CurveAuthenticatesThePeersOfARun) {
  // With the run's keys the exchange works as in the clear; a client with another key pair
  // (someone who learnt the server's public key, but is not this run's coordinator) is refused
  // at the handshake: its messages never arrive, and it hears nothing.
  ASSERT_TRUE(zmq_has("curve")) << "libzmq without CURVE";
  const CurveKeys keys = RunKeys();
  const std::string endpoint = "ipc:///tmp/cosim_curve_test_" + std::to_string(getpid());
  zmq::context_t server_context, client_context, intruder_context;
  ChannelOptions server{endpoint, true, "contact", "smooth", 2.0, 0.05, keys};
  Channel contact(&server_context, server);
  CurveKeys intruder_keys = RunKeys();
  intruder_keys.server_public = keys.server_public;
  Channel intruder(&intruder_context, {endpoint, false, "intruder", "contact", 0.5, 0.05, intruder_keys});
  intruder.Outgoing(-1, 0).mutable_shutdown()->set_reason("not yours");
  intruder.Send();  // queued: the handshake never completes
  Channel smooth(&client_context, {endpoint, false, "smooth", "contact", 2.0, 0.05, keys});
  auto* hello = smooth.Outgoing(-1, 0).mutable_hello();
  hello->set_scenario_name("curve");
  smooth.Send();
  const Envelope& got = contact.ReceiveAny();  // the intruder's Shutdown would come first if it got through
  EXPECT_TRUE(got.has_hello());
  EXPECT_EQ(got.sender(), "smooth");
  contact.Outgoing(-1, 0).mutable_welcome();
  contact.Send();
  EXPECT_NO_THROW(smooth.Receive(Envelope::kWelcome, -1, -1));
  ExpectCode(
      ExitCode::kPeerFailure, [&] { intruder.Receive(Envelope::kWelcome, -1, -1); }, "no message from 'contact'");
  // A coordinator without keys cannot talk to a secured contact process either.
  zmq::context_t plain_context;
  Channel plain(&plain_context, {endpoint, false, "plain", "contact", 0.5, 0.05});
  plain.Outgoing(-1, 0).mutable_hello();
  plain.Send();
  ExpectCode(
      ExitCode::kPeerFailure, [&] { plain.Receive(Envelope::kWelcome, -1, -1); }, "no message from 'contact'");
}

TEST(Channel, ACurveHandshakeGoesThroughWhileTheContactProcessAlreadyWaits) {
  // Seen in CI: with coupling.timeout 1 s (heartbeat 0.1 s) no Hello reached a secured contact
  // process that was already waiting for it when the coordinator connected: its heartbeat
  // thread held the lock the ZAP handler takes between polls while it waited for the socket,
  // which the waiting thread holds through its receive slices, so the handler starved and the
  // handshake stalled past the timeout. Replayed: the contact side waits first, the coordinator
  // connects 0.3 s later; three times, each within the 1 s timeout.
  const CurveKeys keys = RunKeys();
  for (int attempt = 0; attempt < 3; ++attempt) {
    const std::string endpoint =
        "ipc:///tmp/cosim_curve_wait_" + std::to_string(getpid()) + "_" + std::to_string(attempt);
    zmq::context_t server_context, client_context;
    Channel contact(&server_context, {endpoint, true, "contact", "smooth", 1.0, 0.1, keys});
    std::string failure;
    std::thread waiting([&] {
      try {
        contact.Receive(Envelope::kHello, -1, -1);
        contact.Outgoing(-1, 0).mutable_welcome();
        contact.Send();
      } catch (const Error& e) {
        failure = e.what();
      }
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    Channel smooth(&client_context, {endpoint, false, "smooth", "contact", 1.0, 0.1, keys});
    smooth.Outgoing(-1, 0).mutable_hello();
    smooth.Send();
    waiting.join();  // the Hello arrived and was answered, or the wait timed out
    EXPECT_EQ(failure, "") << "attempt " << attempt;
    if (!failure.empty()) break;  // (the contact side's heartbeats would keep this side waiting)
    EXPECT_NO_THROW(smooth.Receive(Envelope::kWelcome, -1, -1)) << "attempt " << attempt;
  }
}

TEST(Channel, MissingOrMalformedKeysAreBadInput) {
  zmq::context_t context;
  CurveKeys partial;
  partial.client_public = RunKeys().client_public;  // a server needs its secret key too
  ExpectCode(
      ExitCode::kBadInput,
      [&] {
        Channel c(&context, {"inproc://keys", true, "contact", "smooth", 1.0, 0.5, partial});
      },
      "COSIM_CURVE_SERVER_SECRET is not set");
  setenv(kCurveClientSecret, "not a key", 1);
  ExpectCode(
      ExitCode::kBadInput, [] { CurveKeysFromEnvironment(); }, "COSIM_CURVE_CLIENT_SECRET is not a CURVE key");
  unsetenv(kCurveClientSecret);
}

TEST(Channel, AnEndpointInUseIsReportedNamingIt) {
  zmq::context_t context;
  Channel first(&context, {"inproc://taken", true, "contact", "smooth", 1.0, 1.0});
  ExpectCode(
      ExitCode::kPeerFailure,
      [&] {
        Channel second(&context, {"inproc://taken", true, "contact2", "smooth", 1.0, 1.0});
      },
      "cannot bind endpoint 'inproc://taken' for peer 'smooth'");
}

}  // namespace
}  // namespace cosim::interface
