#include "interface/coupling/channel.h"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <climits>
#include <cstdlib>
#include <cstring>
#include <zmq.hpp>

#include "interface/base/errors.h"
#include "interface/run/run_driver.h"
#include "interface/scenario/checks.h"

namespace cosim::interface {

namespace {

double Now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

// A receive slice that overran its timeout by more than this [s] means this process was not
// running (Channel::Wait).
constexpr double kNotRunning = 0.5;

// Seconds as ZeroMQ's int milliseconds, saturated (the scenario bounds the timeouts anyway).
int Milliseconds(double seconds) {
  return static_cast<int>(std::clamp(1000.0 * seconds, 0.0, static_cast<double>(INT_MAX)));
}

// A Z85 key of 40 characters that decodes to 32 bytes.
bool ValidKey(const std::string& key) {
  if (key.size() != 40) return false;
  uint8_t decoded[32];
  return zmq_z85_decode(decoded, key.c_str()) != nullptr;
}

constexpr const char* kZapEndpoint = "inproc://zeromq.zap.01";  // fixed by ZeroMQ's RFC 27

}  // namespace

CurveKeys CurveKeysFromEnvironment() {
  auto read = [](const char* name) {
    const char* value = std::getenv(name);
    const std::string key = value == nullptr ? "" : value;
    if (!key.empty() && !ValidKey(key)) {
      throw InputError(std::string("environment: ") + name +
                       " is not a CURVE key (40 Z85 characters, as "
                       "zmq_curve_keypair makes them)");
    }
    return key;
  };
  CurveKeys keys;
  keys.server_public = read(kCurveServerPublic);
  keys.server_secret = read(kCurveServerSecret);
  keys.client_public = read(kCurveClientPublic);
  keys.client_secret = read(kCurveClientSecret);
  return keys;
}

std::string BodyName(coupling::Envelope::BodyCase body) {
  switch (body) {
    case coupling::Envelope::kHello:
      return "Hello";
    case coupling::Envelope::kWelcome:
      return "Welcome";
    case coupling::Envelope::kStepBegin:
      return "StepBegin";
    case coupling::Envelope::kReactions:
      return "Reactions";
    case coupling::Envelope::kKinematics:
      return "Kinematics";
    case coupling::Envelope::kStepEnd:
      return "StepEnd";
    case coupling::Envelope::kShutdown:
      return "Shutdown";
    case coupling::Envelope::kHeartbeat:
      return "Heartbeat";
    case coupling::Envelope::BODY_NOT_SET:
      return "a message without body";
  }
  return "an unknown message";
}

Channel::Channel(zmq::context_t* context, ChannelOptions options)
    : options_(std::move(options)),
      context_(context),
      socket_(std::make_unique<zmq::socket_t>(*context, zmq::socket_type::dealer)) {
  const int heartbeat_ms = Milliseconds(options_.heartbeat);
  const int timeout_ms = Milliseconds(options_.timeout);
  // A last reply (to Shutdown) must reach the peer after this side closes; a dead peer must
  // not hold the close up for long.
  socket_->set(zmq::sockopt::linger, std::min(1000, timeout_ms));
  socket_->set(zmq::sockopt::heartbeat_ivl, heartbeat_ms);
  socket_->set(zmq::sockopt::heartbeat_timeout, timeout_ms);
  socket_->set(zmq::sockopt::heartbeat_ttl, timeout_ms);
  socket_->set(zmq::sockopt::sndtimeo, timeout_ms);  // a gone peer: no endless blocking send
  const CurveKeys& keys = options_.keys;
  if (!keys.empty()) {
    auto require = [&](const std::string& key, const char* name) {
      if (key.empty()) {
        throw InputError(std::string("environment: ") + name + " is not set, but other COSIM_CURVE_* keys are: the " +
                         (options_.bind ? "contact process" : "coordinator") +
                         " needs it for the coupling's CURVE security (docs/protocol.md, \"Security\")");
      }
    };
    if (options_.bind) {
      require(keys.server_secret, kCurveServerSecret);
      require(keys.client_public, kCurveClientPublic);
      // Only the run's own client may connect: a ZAP handler checks its key at the handshake.
      zap_ = std::make_unique<zmq::socket_t>(*context_, zmq::socket_type::rep);
      try {
        zap_->bind(kZapEndpoint);
      } catch (const zmq::error_t& e) {
        throw PeerError(std::string("coupling: cannot start the CURVE authentication handler: ") + e.what());
      }
      socket_->set(zmq::sockopt::curve_server, 1);
      socket_->set(zmq::sockopt::curve_secretkey, keys.server_secret);
      socket_->set(zmq::sockopt::zap_domain, "cosim");
      zap_thread_ = std::thread(&Channel::Authenticate, this);
    } else {
      require(keys.server_public, kCurveServerPublic);
      require(keys.client_public, kCurveClientPublic);
      require(keys.client_secret, kCurveClientSecret);
      socket_->set(zmq::sockopt::curve_serverkey, keys.server_public);
      socket_->set(zmq::sockopt::curve_publickey, keys.client_public);
      socket_->set(zmq::sockopt::curve_secretkey, keys.client_secret);
    }
  }
  try {
    if (options_.bind) {
      socket_->bind(options_.endpoint);
    } else {
      socket_->connect(options_.endpoint);
    }
  } catch (const zmq::error_t& e) {
    {
      std::lock_guard<std::mutex> lock(stop_mutex_);
      stopping_ = true;
    }
    if (zap_thread_.joinable()) zap_thread_.join();
    throw PeerError("coupling: cannot " + std::string(options_.bind ? "bind" : "connect to") + " endpoint '" +
                    options_.endpoint + "' for peer '" + options_.peer + "': " + e.what() +
                    " (expected tcp://host:port, ipc://path or inproc://name, not in use)");
  }
  coupling::Envelope heartbeat;
  heartbeat.set_protocol_version(coupling::PROTOCOL_VERSION_CURRENT);
  heartbeat.set_sender(options_.self);
  heartbeat.set_step(-1);
  heartbeat.mutable_heartbeat();
  heartbeat.SerializeToString(&heartbeat_bytes_);
  last_send_ = Now();
  pump_ = std::thread(&Channel::PumpHeartbeats, this);
}

Channel::~Channel() {
  {
    std::lock_guard<std::mutex> lock(stop_mutex_);
    stopping_ = true;
  }
  stop_.notify_all();
  if (pump_.joinable()) pump_.join();
  if (zap_thread_.joinable()) zap_thread_.join();
}

long long Channel::heartbeats_sent() const {
  std::lock_guard<std::mutex> lock(socket_mutex_);
  return heartbeats_;
}

void Channel::HeartbeatIfDue() {
  const double now = Now();
  if (now - last_send_ < options_.heartbeat) return;
  // Never blocks: with no peer connected (yet, or any more) there is nobody to keep waiting.
  const auto sent = socket_->send(zmq::buffer(heartbeat_bytes_), zmq::send_flags::dontwait);
  if (sent) ++heartbeats_;
  last_send_ = now;
}

void Channel::PumpHeartbeats() {
  const auto period = std::chrono::duration<double>(std::max(1e-3, 0.5 * options_.heartbeat));
  std::unique_lock<std::mutex> stop_lock(stop_mutex_);
  while (!stop_.wait_for(stop_lock, period, [this] { return stopping_; })) {
    // Not holding stop_mutex_ while waiting for the socket: the caller's thread holds the socket
    // through its receive slices, and the CURVE server's ZAP handler takes stop_mutex_ between
    // polls — held here, it starved the handler and the connection's handshake stalled for
    // hundreds of milliseconds (with heartbeat 0.1 s no Hello got through in 1 s).
    stop_lock.unlock();
    {
      std::lock_guard<std::mutex> lock(socket_mutex_);
      try {
        HeartbeatIfDue();
      } catch (const zmq::error_t&) {
        // The context is ending: nothing to keep alive.
      }
    }
    stop_lock.lock();
  }
}

void Channel::Authenticate() {
  // ZAP (ZeroMQ RFC 27): request [version, id, domain, address, identity, mechanism, key];
  // reply [version, id, status, text, user id, metadata]. Only the run's client key passes.
  uint8_t expected[32];
  zmq_z85_decode(expected, options_.keys.client_public.c_str());
  zmq::pollitem_t item{static_cast<void*>(*zap_), 0, ZMQ_POLLIN, 0};
  while (true) {
    {
      std::lock_guard<std::mutex> lock(stop_mutex_);
      if (stopping_) break;
    }
    try {
      if (zmq::poll(&item, 1, std::chrono::milliseconds(100)) == 0) continue;
      std::vector<zmq::message_t> frames;
      while (true) {
        zmq::message_t frame;
        if (!zap_->recv(frame, zmq::recv_flags::none)) break;
        const bool more = frame.more();
        frames.push_back(std::move(frame));
        if (!more) break;
      }
      if (frames.size() < 6) continue;  // not a ZAP request: REP needs a reply anyway
      const bool curve = frames[5].to_string() == "CURVE";
      const bool ours =
          curve && frames.size() >= 7 && frames[6].size() == 32 && std::memcmp(frames[6].data(), expected, 32) == 0;
      zap_->send(zmq::str_buffer("1.0"), zmq::send_flags::sndmore);
      zap_->send(frames[1], zmq::send_flags::sndmore);
      zap_->send(zmq::buffer(std::string(ours ? "200" : "400")), zmq::send_flags::sndmore);
      zap_->send(zmq::buffer(std::string(ours ? "OK" : "not this run's coordinator")), zmq::send_flags::sndmore);
      zap_->send(zmq::str_buffer(""), zmq::send_flags::sndmore);
      zap_->send(zmq::str_buffer(""), zmq::send_flags::none);
    } catch (const zmq::error_t&) {
      break;  // the context is ending
    }
  }
  zap_->close();
}

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
  std::lock_guard<std::mutex> lock(socket_mutex_);
  zmq::send_result_t sent;
  try {
    // Queued by ZeroMQ (the peer may not have connected yet); blocks only while no peer is
    // connected, and then at most `timeout`.
    sent = socket_->send(zmq::buffer(send_buffer_), zmq::send_flags::none);
  } catch (const zmq::error_t& e) {
    throw PeerError("coupling: sending " + BodyName(outgoing_.body_case()) + " to '" + options_.peer +
                    "' failed: " + e.what());
  }
  if (!sent) {
    throw PeerError("coupling: could not send " + BodyName(outgoing_.body_case()) + " to '" + options_.peer + "' (" +
                    options_.endpoint + ") for " + FormatNumber(options_.timeout) +
                    " s: the peer is gone (coupling.timeout)");
  }
  last_send_ = Now();
}

std::string Channel::Describe(const coupling::Envelope& e) const {
  return BodyName(e.body_case()) + " of step " + std::to_string(e.step()) + ", iteration " +
         std::to_string(e.iteration());
}

const coupling::Envelope& Channel::Wait(const std::string& awaiting, double timeout) {
  const auto now = [this] { return options_.clock ? options_.clock() : Now(); };
  double mark = now();  // the last reading of the clock
  double deadline = mark + timeout;
  double allowed = 0.0;  // how long the time since `mark` may have taken: the receive slice run since
  zmq::message_t message;
  while (true) {
    // Time since the last reading beyond the receive slice run since: this process did not run
    // (stopped by ^Z or SIGSTOP with its run, or starved), during a receive or between two.
    // That time is not the peer's silence: the deadline moves by it (otherwise a run suspended
    // for longer than coupling.timeout ends on resume). Measured from reading to reading, so that
    // no moment of the wait escapes it.
    const double t = now();
    const double away = t - mark - allowed;
    if (away > kNotRunning) deadline += away;
    mark = t;
    allowed = 0.0;
    const double left = deadline - t;
    if (left <= 0.0) {
      throw PeerError("coupling: no message from '" + options_.peer + "' (" + options_.endpoint + ") for " +
                      FormatNumber(options_.timeout) + " s while waiting for " + awaiting +
                      "; the peer died, was stopped, never started or refused this side's key (coupling.timeout)");
    }
    if (TerminationRequested()) {
      throw PeerError("coupling: terminated by a signal while waiting for " + awaiting + " from '" + options_.peer +
                      "' (the launcher stops the processes of a run when one of them fails: see the others' logs)");
    }
    // A blocking receive bounded by the time left, in slices of at most 0.2 s (and of the
    // heartbeat period) to notice a termination request and to keep this side's heartbeats
    // going (a message ends the wait at once: the round trip does not pay).
    bool received = false;
    {
      std::lock_guard<std::mutex> lock(socket_mutex_);
      HeartbeatIfDue();
      const double slice = std::min({left, 0.2, options_.heartbeat});
      socket_->set(zmq::sockopt::rcvtimeo, Milliseconds(slice) + 1);
      allowed = slice;
      try {
        received = socket_->recv(message, zmq::recv_flags::none).has_value();
      } catch (const zmq::error_t& e) {
        if (e.num() != EINTR) throw;  // a signal interrupted the wait: checked above
      }
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
    if (incoming_.has_heartbeat()) {  // alive, busy: the wait starts again
      mark = now();
      allowed = 0.0;
      deadline = mark + options_.timeout;
      continue;
    }
    peer_stopped_ = peer_stopped_ || incoming_.has_shutdown();
    return incoming_;
  }
}

const coupling::Envelope& Channel::ReceiveAny() { return Wait("its next message", options_.timeout); }

const coupling::Envelope& Channel::Receive(coupling::Envelope::BodyCase expected, int64_t step, int iteration) {
  return Receive(expected, step, iteration, options_.timeout);
}

const coupling::Envelope& Channel::Receive(coupling::Envelope::BodyCase expected, int64_t step, int iteration,
                                           double timeout) {
  std::string awaiting = BodyName(expected);
  if (step >= 0) awaiting += " of step " + std::to_string(step);
  if (iteration >= 0) awaiting += ", iteration " + std::to_string(iteration);
  const coupling::Envelope& e = Wait(awaiting, timeout);
  if (e.has_shutdown() && expected != coupling::Envelope::kShutdown) {
    // The peer's own failure is the run's: its bad input (2) or numerical failure (3) ends
    // this side with the same code; anything else is a peer failure.
    const int code = e.shutdown().exit_code();
    ThrowAs(PeerOutcome(code), "coupling: '" + options_.peer + "' stopped (exit code " + std::to_string(code) +
                                   ") while this side waited for " + awaiting + ": " +
                                   EchoedText(e.shutdown().reason()));
  }
  if (e.body_case() != expected || (step >= 0 && e.step() != step) || (iteration >= 0 && e.iteration() != iteration)) {
    throw InputError("coupling: out-of-order message from '" + options_.peer + "': got " + Describe(e) + ", expected " +
                     awaiting);
  }
  return e;
}

}  // namespace cosim::interface
