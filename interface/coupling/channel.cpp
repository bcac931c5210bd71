#include "interface/coupling/channel.h"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <zmq.hpp>

#include "interface/run/errors.h"
#include "interface/run/run_driver.h"
#include "interface/scenario/checks.h"

namespace cosim::interface {

namespace {

double Now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace

std::string BodyName(coupling::Envelope::BodyCase body) {
  switch (body) {
    case coupling::Envelope::kHello: return "Hello";
    case coupling::Envelope::kWelcome: return "Welcome";
    case coupling::Envelope::kStepBegin: return "StepBegin";
    case coupling::Envelope::kReactions: return "Reactions";
    case coupling::Envelope::kKinematics: return "Kinematics";
    case coupling::Envelope::kStepEnd: return "StepEnd";
    case coupling::Envelope::kShutdown: return "Shutdown";
    case coupling::Envelope::kHeartbeat: return "Heartbeat";
    case coupling::Envelope::BODY_NOT_SET: return "a message without body";
  }
  return "an unknown message";
}

Channel::Channel(zmq::context_t* context, ChannelOptions options)
    : options_(std::move(options)), socket_(std::make_unique<zmq::socket_t>(*context, zmq::socket_type::dealer)) {
  const int heartbeat_ms = static_cast<int>(1000.0 * options_.heartbeat);
  const int timeout_ms = static_cast<int>(1000.0 * options_.timeout);
  // A last reply (to Shutdown) must reach the peer after this side closes; a dead peer must
  // not hold the close up for long.
  socket_->set(zmq::sockopt::linger, static_cast<int>(std::min(1000.0, timeout_ms * 1.0)));
  socket_->set(zmq::sockopt::heartbeat_ivl, heartbeat_ms);
  socket_->set(zmq::sockopt::heartbeat_timeout, timeout_ms);
  socket_->set(zmq::sockopt::heartbeat_ttl, timeout_ms);
  try {
    if (options_.bind) {
      socket_->bind(options_.endpoint);
    } else {
      socket_->connect(options_.endpoint);
    }
  } catch (const zmq::error_t& e) {
    throw PeerError("coupling: cannot " + std::string(options_.bind ? "bind" : "connect to") + " endpoint '" +
                    options_.endpoint + "' for peer '" + options_.peer + "': " + e.what() +
                    " (expected tcp://host:port, ipc://path or inproc://name, not in use)");
  }
  last_send_ = Now();
}

Channel::~Channel() = default;

coupling::Envelope& Channel::Outgoing(int64_t step, int iteration) {
  outgoing_.Clear();
  outgoing_.set_protocol_version(coupling::PROTOCOL_VERSION_CURRENT);
  outgoing_.set_sender(options_.self);
  outgoing_.set_step(step);
  outgoing_.set_iteration(iteration);
  return outgoing_;
}

void Channel::Send() {
  outgoing_.SerializeToString(&send_buffer_);
  try {
    // Blocking send: ZeroMQ queues it (the peer may not have connected yet).
    socket_->send(zmq::buffer(send_buffer_), zmq::send_flags::none);
  } catch (const zmq::error_t& e) {
    throw PeerError("coupling: sending " + BodyName(outgoing_.body_case()) + " to '" + options_.peer +
                    "' failed: " + e.what());
  }
  last_send_ = Now();
}

void Channel::MaybeHeartbeat() {
  if (Now() - last_send_ < options_.heartbeat) return;
  const int64_t step = outgoing_.step();
  const int iteration = outgoing_.iteration();
  Outgoing(step, iteration).mutable_heartbeat();
  Send();
}

std::string Channel::Describe(const coupling::Envelope& e) const {
  return BodyName(e.body_case()) + " of step " + std::to_string(e.step()) + ", iteration " +
         std::to_string(e.iteration());
}

const coupling::Envelope& Channel::Wait(const std::string& awaiting) {
  double deadline = Now() + options_.timeout;
  zmq::message_t message;
  while (true) {
    const double left = deadline - Now();
    if (left <= 0.0) {
      throw PeerError("coupling: no message from '" + options_.peer + "' (" + options_.endpoint + ") for " +
                      FormatNumber(options_.timeout) + " s while waiting for " + awaiting +
                      "; the peer died, hung or never started (coupling.timeout)");
    }
    if (TerminationRequested()) {
      throw PeerError("coupling: terminated by a signal while waiting for " + awaiting + " from '" + options_.peer +
                      "' (the launcher stops the processes of a run when one of them fails: see the others' logs)");
    }
    // A blocking receive bounded by the time left, in slices of at most 0.2 s to notice a
    // termination request (a message ends the wait at once: the round trip does not pay).
    socket_->set(zmq::sockopt::rcvtimeo, static_cast<int>(1000.0 * std::min(left, 0.2)) + 1);
    bool received = false;
    try {
      received = socket_->recv(message, zmq::recv_flags::none).has_value();
    } catch (const zmq::error_t& e) {
      if (e.num() != EINTR) throw;  // a signal interrupted the wait: checked above
    }
    if (!received) continue;  // timed out or interrupted: checked above
    if (!incoming_.ParseFromArray(message.data(), static_cast<int>(message.size()))) {
      throw InputError("coupling: a malformed message (" + std::to_string(message.size()) + " bytes) from '" +
                       options_.peer + "' while waiting for " + awaiting +
                       "; expected a cosim.coupling.Envelope (proto/coupling.proto)");
    }
    if (incoming_.protocol_version() != coupling::PROTOCOL_VERSION_CURRENT) {
      throw InputError("coupling: '" + options_.peer + "' speaks protocol version " +
                       std::to_string(incoming_.protocol_version()) + ", this program speaks version " +
                       std::to_string(coupling::PROTOCOL_VERSION_CURRENT) + " (proto/coupling.proto)");
    }
    if (incoming_.has_heartbeat()) {
      deadline = Now() + options_.timeout;  // alive, busy
      continue;
    }
    return incoming_;
  }
}

const coupling::Envelope& Channel::ReceiveAny() { return Wait("its next message"); }

const coupling::Envelope& Channel::Receive(coupling::Envelope::BodyCase expected, int64_t step, int iteration) {
  std::string awaiting = BodyName(expected);
  if (step >= 0) awaiting += " of step " + std::to_string(step);
  if (iteration >= 0) awaiting += ", iteration " + std::to_string(iteration);
  const coupling::Envelope& e = Wait(awaiting);
  if (e.has_shutdown() && expected != coupling::Envelope::kShutdown) {
    throw PeerError("coupling: '" + options_.peer + "' stopped (exit code " + std::to_string(e.shutdown().exit_code()) +
                    ") while this side waited for " + awaiting + ": " + e.shutdown().reason());
  }
  if (e.body_case() != expected || (step >= 0 && e.step() != step) || (iteration >= 0 && e.iteration() != iteration)) {
    throw InputError("coupling: out-of-order message from '" + options_.peer + "': got " + Describe(e) +
                     ", expected " + awaiting);
  }
  return e;
}

}  // namespace cosim::interface
