#pragma once
// One side of the coupling protocol's connection to one peer process (proto/coupling.proto,
// docs/protocol.md) over ZeroMQ: tcp://, ipc:// or inproc:// (tests).
//
// Both ends are DEALER sockets (asynchronous, so that heartbeats can flow while a side is
// busy); the contact process binds its endpoint, the coordinator connects (either may start
// first). A dead or hung peer is detected by the receive timeout: no message for `timeout`
// seconds ends the wait with a PeerError (exit code 4) naming the peer and what was awaited.
// Heartbeats from the peer restart the wait; ZeroMQ's own ZMTP heartbeats (every `heartbeat`
// seconds) drop a connection whose peer vanished. Messages are checked on arrival: one that
// does not parse, speaks another protocol version, or is not the one expected (body, step,
// iteration) is refused with an InputError (exit code 2) that says what came and what was due.
//
// Buffers are kept between messages: a steady exchange does not allocate once the message
// sizes have been seen.
#include <cstdint>
#include <memory>
#include <string>

#include "coupling.pb.h"

namespace zmq {
class context_t;
class socket_t;
}  // namespace zmq

namespace cosim::interface {

struct ChannelOptions {
  std::string endpoint;   // tcp://host:port, ipc://path or inproc://name
  bool bind = false;      // the contact process binds, the coordinator connects
  std::string self;       // this process's name (Envelope.sender)
  std::string peer;       // the peer's name, for messages
  double timeout = 10.0;  // [s] without any message from the peer
  double heartbeat = 1.0; // [s] between heartbeats (ZMTP and MaybeHeartbeat)
};

class Channel {
 public:
  // Throws PeerError if the endpoint cannot be bound or connected (naming it).
  Channel(zmq::context_t* context, ChannelOptions options);
  ~Channel();
  Channel(const Channel&) = delete;
  Channel& operator=(const Channel&) = delete;

  // A message to fill and send: version and sender are set, the body cleared.
  coupling::Envelope& Outgoing(int64_t step, int iteration);
  void Send();  // sends Outgoing()
  const coupling::Envelope& outgoing() const { return outgoing_; }  // as filled, not cleared

  // The next message that is not a heartbeat, parsed and checked: its body must be `expected`,
  // and its step and iteration the given ones (checked when >= 0 / >= 0). `awaiting` says
  // what is waited for ("Kinematics of step 12, iteration 3"), for the messages.
  const coupling::Envelope& Receive(coupling::Envelope::BodyCase expected, int64_t step, int iteration);
  // As Receive, but any body is accepted (the contact process's main loop dispatches on it).
  const coupling::Envelope& ReceiveAny();

  // Sends a heartbeat if `heartbeat` seconds have passed since this side last sent anything.
  void MaybeHeartbeat();

  const ChannelOptions& options() const { return options_; }
  // Raw access for the transport benchmark.
  zmq::socket_t& socket() { return *socket_; }

 private:
  const coupling::Envelope& Wait(const std::string& awaiting);
  std::string Describe(const coupling::Envelope& e) const;

  ChannelOptions options_;
  std::unique_ptr<zmq::socket_t> socket_;
  coupling::Envelope outgoing_, incoming_;
  std::string send_buffer_;
  double last_send_ = 0.0;
};

// Name of an envelope body for messages ("Kinematics", "StepEnd", ...).
std::string BodyName(coupling::Envelope::BodyCase body);

}  // namespace cosim::interface
