#pragma once
// One side of the coupling protocol's connection to one peer process (proto/coupling.proto,
// docs/protocol.md) over ZeroMQ: tcp://, ipc:// or inproc:// (tests).
//
// Both ends are DEALER sockets (asynchronous, so that heartbeats can flow while a side is
// busy); the contact process binds its endpoint, the coordinator connects (either may start
// first). A dead or hung peer is detected by the receive timeout: no message for `timeout`
// seconds ends the wait with a PeerError (exit code 4) naming the peer and what was awaited.
// A background thread sends a Heartbeat whenever this side has sent nothing for `heartbeat`
// seconds — while its step computes, or while it waits for another peer — and the peer's
// wait starts again at each one; a stopped process (SIGSTOP) sends none. ZeroMQ's own ZMTP
// heartbeats drop a connection whose peer vanished. A send that cannot be delivered within
// `timeout` (the peer is gone) ends with a PeerError instead of blocking for ever. Messages
// are checked on arrival: one that does not parse, speaks another protocol version, or is not
// the one expected (body, step, iteration) is refused with an InputError (exit code 2) that
// says what came and what was due; a peer's Shutdown reporting its own failure (exit 2 or 3)
// ends the wait with that code and the peer's reason.
//
// Security: with CURVE keys (CurveKeys, from the environment the launcher gives its
// children) the connection is encrypted and both ends authenticated: the binding side
// (server) accepts only the client key of its run, the connecting side only the server key.
//
// The socket is used by the caller's thread and the heartbeat thread in turn, under a mutex
// (ZeroMQ allows a socket to move between threads with a full barrier). Buffers are kept
// between messages: a steady exchange does not allocate once the message sizes have been seen.
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "coupling.pb.h"

namespace zmq {
class context_t;
class socket_t;
}  // namespace zmq

namespace cosim::interface {

// A coupled run's CURVE keys (Z85 text, 40 characters each), as the launcher passes them to
// its children in the environment variables below. A contact process (server) needs the
// server's secret key and the client's public key; the coordinator (client) its own key pair
// and the server's public key. Empty: no security (a channel between processes started by
// hand, and the tests).
inline constexpr const char* kCurveServerPublic = "COSIM_CURVE_SERVER_PUBLIC";
inline constexpr const char* kCurveServerSecret = "COSIM_CURVE_SERVER_SECRET";
inline constexpr const char* kCurveClientPublic = "COSIM_CURVE_CLIENT_PUBLIC";
inline constexpr const char* kCurveClientSecret = "COSIM_CURVE_CLIENT_SECRET";
// Set ("1") by the launcher for the contact processes it starts: they wait for the Hello
// without coupling.timeout, since the launcher stops them if the coordinator ends before it
// (a coordinator building a large model says nothing for longer than any timeout).
inline constexpr const char* kSupervisedVariable = "COSIM_SUPERVISED";
struct CurveKeys {
  std::string server_public, server_secret, client_public, client_secret;
  bool empty() const {
    return server_public.empty() && server_secret.empty() && client_public.empty() && client_secret.empty();
  }
};
// The keys in this process's environment; InputError naming the variable for a malformed key.
CurveKeys CurveKeysFromEnvironment();

struct ChannelOptions {
  std::string endpoint;    // tcp://host:port, ipc://path or inproc://name
  bool bind = false;       // the contact process binds, the coordinator connects
  std::string self;        // this process's name (Envelope.sender)
  std::string peer;        // the peer's name, for messages
  double timeout = 10.0;   // [s] without any message from the peer
  double heartbeat = 1.0;  // [s] between heartbeats (ZMTP and the heartbeat thread)
  CurveKeys keys = {};     // empty: no CURVE security
  // The monotonic clock [s] the peer's silence is measured by; empty: the steady clock. (Tests
  // give one that jumps, as a process stopped between two of its readings sees it.)
  std::function<double()> clock = {};
};

class Channel {
 public:
  // Throws PeerError if the endpoint cannot be bound or connected (naming it), InputError if
  // the keys this side needs are missing.
  Channel(zmq::context_t* context, ChannelOptions options);
  ~Channel();
  Channel(const Channel&) = delete;
  Channel& operator=(const Channel&) = delete;

  // A message to fill and send: version and sender are set, the body cleared.
  coupling::Envelope& Outgoing(int64_t step, int iteration);
  void Send();  // sends Outgoing(); PeerError if it cannot be delivered within the timeout
  const coupling::Envelope& outgoing() const { return outgoing_; }  // as filled, not cleared

  // The next message that is not a heartbeat, parsed and checked: its body must be `expected`,
  // and its step and iteration the given ones (checked when >= 0 / >= 0).
  const coupling::Envelope& Receive(coupling::Envelope::BodyCase expected, int64_t step, int iteration);
  // The same, waiting at most `timeout` seconds (infinity: until a message, a termination
  // request or the peer's end) instead of options().timeout.
  const coupling::Envelope& Receive(coupling::Envelope::BodyCase expected, int64_t step, int iteration, double timeout);
  // As Receive, but any body is accepted (the contact process's main loop dispatches on it).
  const coupling::Envelope& ReceiveAny();

  const ChannelOptions& options() const { return options_; }
  // The peer sent its Shutdown (it has ended or is ending: no more messages to it).
  bool peer_stopped() const { return peer_stopped_; }
  long long heartbeats_sent() const;
  // Raw access for the transport benchmark and tests (not while the channel is in use).
  zmq::socket_t& socket() { return *socket_; }

 private:
  const coupling::Envelope& Wait(const std::string& awaiting, double timeout);
  std::string Describe(const coupling::Envelope& e) const;
  void HeartbeatIfDue();  // with the socket's mutex held
  void PumpHeartbeats();  // the heartbeat thread
  void Authenticate();    // the ZAP handler thread of a CURVE server

  ChannelOptions options_;
  zmq::context_t* context_;
  std::unique_ptr<zmq::socket_t> socket_;
  coupling::Envelope outgoing_, incoming_;
  std::string send_buffer_, heartbeat_bytes_;
  mutable std::mutex socket_mutex_;  // the socket, last_send_, heartbeats_
  double last_send_ = 0.0;
  long long heartbeats_ = 0;
  bool peer_stopped_ = false;
  std::mutex stop_mutex_;
  std::condition_variable stop_;
  bool stopping_ = false;
  std::unique_ptr<zmq::socket_t> zap_;  // the ZAP handler's socket (CURVE server only)
  std::thread pump_, zap_thread_;
};

// Name of an envelope body for messages ("Kinematics", "StepEnd", ...).
std::string BodyName(coupling::Envelope::BodyCase body);

}  // namespace cosim::interface
