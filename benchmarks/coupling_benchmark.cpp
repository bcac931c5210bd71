// Coupling-transport benchmark (not a test): the round trip of one coupling exchange of the
// real messages (Reactions → Kinematics, serialised, sent, received, parsed and checked on both
// sides) against a raw ZeroMQ ping-pong of the same byte sizes over the same transport, in one
// run, for ipc and tcp, between two processes (fork), for 1 and 12 interface nodes.
// Target: the protocol within 1.25× of the raw ping-pong. Peer figures on this kind of
// machine (docs/reference/peers.md): ipc 38-79 µs, tcp 44-81 µs per round trip.
#include <google/protobuf/util/json_util.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <zmq.hpp>

#include "interface/coupling/channel.h"
#include "run_summary.pb.h"

namespace {

using cosim::coupling::Envelope;
using cosim::interface::Channel;
using cosim::interface::ChannelOptions;

constexpr int kWarmup = 200, kRounds = 5000;

// The contact side's replies: Kinematics for `nodes` nodes.
void FillKinematics(Envelope& e, int nodes) {
  auto* k = e.mutable_kinematics();
  for (int i = 0; i < 3 * nodes; ++i) {
    k->add_position(0.1 * i);
    k->add_velocity(-0.2 * i);
  }
  for (int i = 0; i < nodes; ++i) k->add_in_contact(i % 2);
}

void FillReactions(Envelope& e, int nodes) {
  auto* r = e.mutable_reactions();
  for (int i = 0; i < 3 * nodes; ++i) r->add_force(1.5 * i + 0.25);
}

// Child: echo raw bytes (reply of `reply_size` bytes), then serve the protocol until Shutdown.
void Serve(const std::string& endpoint, const std::string& raw_endpoint, int nodes, size_t reply_size) {
  zmq::context_t context;
  {
    zmq::socket_t raw(context, zmq::socket_type::dealer);
    raw.set(zmq::sockopt::linger, 1000);  // the last reply must leave before the socket closes
    raw.bind(raw_endpoint);
    std::string reply(reply_size, 'x');
    zmq::message_t m;
    for (int r = 0; r < kWarmup + kRounds; ++r) {
      (void)raw.recv(m, zmq::recv_flags::none);
      raw.send(zmq::buffer(reply), zmq::send_flags::none);
    }
  }
  Channel c(&context, ChannelOptions{endpoint, true, "contact", "smooth", 10.0, 1.0});
  while (true) {
    const Envelope& e = c.ReceiveAny();
    if (e.has_shutdown()) break;
    FillKinematics(c.Outgoing(e.step(), 0), nodes);
    c.Send();
  }
}

double RawRoundTrip(zmq::context_t& context, const std::string& endpoint, size_t request_size) {
  zmq::socket_t raw(context, zmq::socket_type::dealer);
  raw.set(zmq::sockopt::linger, 0);
  raw.connect(endpoint);
  std::string request(request_size, 'y');
  zmq::message_t m;
  auto t0 = std::chrono::steady_clock::now();
  for (int r = 0; r < kWarmup + kRounds; ++r) {
    if (r == kWarmup) t0 = std::chrono::steady_clock::now();
    raw.send(zmq::buffer(request), zmq::send_flags::none);
    (void)raw.recv(m, zmq::recv_flags::none);
  }
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / kRounds;
}

double ProtocolRoundTrip(zmq::context_t& context, const std::string& endpoint, int nodes) {
  Channel c(&context, ChannelOptions{endpoint, false, "smooth", "contact", 10.0, 1.0});
  auto t0 = std::chrono::steady_clock::now();
  for (int r = 0; r < kWarmup + kRounds; ++r) {
    if (r == kWarmup) t0 = std::chrono::steady_clock::now();
    FillReactions(c.Outgoing(r, 0), nodes);
    c.Send();
    const Envelope& k = c.Receive(Envelope::kKinematics, r, 0);
    if (k.kinematics().position_size() != 3 * nodes) std::abort();
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / kRounds;
  c.Outgoing(-1, 0).mutable_shutdown();
  c.Send();
  return seconds;
}

// The relaxation methods on the coupled scenes: every run through cosim_launch (next to this
// executable), mean and largest coupling iterations per step and wall time from summary.json.
void RelaxationTable() {
  char self[4096];
  const ssize_t n = readlink("/proc/self/exe", self, sizeof(self) - 1);
  if (n <= 0) return;
  self[n] = '\0';
  const std::string bin = std::filesystem::path(self).parent_path().string();
  const std::string out = "/tmp/cosim_relaxation_bench_" + std::to_string(getpid());
  struct Case {
    const char* scene;
    const char* label;
    const char* sets;
  };
  const Case cases[] = {
      {"pendulum_stop", "CONSTANT w=0.05",
       "--set coupling.iteration.relaxation=CONSTANT --set coupling.iteration.relaxation_factor=0.05 --set "
       "coupling.iteration.max_iterations=200"},
      {"pendulum_stop", "AITKEN", "--set coupling.iteration.relaxation=AITKEN"},
      {"pendulum_stop", "IQN-ILS",
       "--set coupling.iteration.relaxation=IQN_ILS --set coupling.iteration.reuse_steps=0"},
      {"pendulum_stop", "IQN-ILS(4)",
       "--set coupling.iteration.relaxation=IQN_ILS --set coupling.iteration.reuse_steps=4"},
      {"pendulum_stop", "IQN-ILS(16)",
       "--set coupling.iteration.relaxation=IQN_ILS --set coupling.iteration.reuse_steps=16"},
      {"tied_drop", "CONSTANT w=0.5", "--set coupling.iteration.relaxation=CONSTANT"},
      {"tied_drop", "AITKEN", "--set coupling.iteration.relaxation=AITKEN"},
      {"tied_drop", "IQN-ILS", "--set coupling.iteration.relaxation=IQN_ILS"},
      {"tied_drop", "IQN-ILS(4)", "--set coupling.iteration.relaxation=IQN_ILS --set coupling.iteration.reuse_steps=4"},
      {"linear_oscillator", "AITKEN", "--set coupling.iteration.relaxation=AITKEN"},
      {"linear_oscillator", "IQN-ILS(4)",
       "--set coupling.iteration.relaxation=IQN_ILS --set coupling.iteration.reuse_steps=4"},
  };
  std::printf("\ncoupling iterations per step (all steps converged unless the exit code says otherwise)\n");
  std::printf("%-18s %-16s %5s %10s %8s %10s\n", "scene", "relaxation", "exit", "mean/step", "max", "wall [s]");
  for (const Case& c : cases) {
    const std::string command = bin + "/cosim_launch " + std::string(COSIM_SOURCE_DIR) + "/scenarios/" + c.scene +
                                ".pbtxt --out " + out + " " + c.sets + " > /dev/null 2>&1";
    const int status = std::system(command.c_str());
    const int code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    std::ifstream in(out + "/summary.json");
    std::stringstream text;
    text << in.rdbuf();
    cosim::run::RunSummary summary;
    if (!google::protobuf::util::JsonStringToMessage(text.str(), &summary).ok()) continue;
    std::printf("%-18s %-16s %5d %10.2f %8d %10.2f\n", c.scene, c.label, code,
                summary.coupling_iterations().mean_per_step(), summary.coupling_iterations().max_per_step(),
                summary.wall_time());
    std::filesystem::remove_all(out);
  }
}

}  // namespace

int main() {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  std::printf("%-5s %6s %12s %10s %10s %15s %7s\n", "", "nodes", "request [B]", "reply [B]", "raw [us]",
              "protocol [us]", "ratio");
  int case_id = 0;
  for (const std::string transport : {"ipc", "tcp"}) {
    for (int nodes : {1, 12}) {
      std::string endpoint, raw_endpoint;
      if (transport == "ipc") {
        endpoint = "ipc:///tmp/cosim_coupling_bench_" + std::to_string(getpid()) + "_" + std::to_string(case_id);
        raw_endpoint = endpoint + "_raw";
      } else {
        endpoint = "tcp://127.0.0.1:" + std::to_string(47000 + 2 * case_id);
        raw_endpoint = "tcp://127.0.0.1:" + std::to_string(47001 + 2 * case_id);
      }
      ++case_id;
      // Byte sizes of the real messages (a step number of the run's varint length). No ZeroMQ
      // context may exist across fork().
      Envelope sized;
      sized.set_protocol_version(cosim::coupling::PROTOCOL_VERSION_CURRENT);
      sized.set_sender("smooth");
      sized.set_step(1000);
      sized.set_iteration(0);
      FillReactions(sized, nodes);
      const size_t request_size = sized.ByteSizeLong();
      sized.set_sender("contact");
      FillKinematics(sized, nodes);  // the oneof body switches to Kinematics
      const size_t reply_size = sized.ByteSizeLong();
      const pid_t child = fork();
      if (child == 0) {
        Serve(endpoint, raw_endpoint, nodes, reply_size);
        _exit(0);
      }
      zmq::context_t context;
      const double raw = RawRoundTrip(context, raw_endpoint, request_size);
      const double protocol = ProtocolRoundTrip(context, endpoint, nodes);
      waitpid(child, nullptr, 0);
      std::printf("%-5s %6d %12zu %10zu %10.1f %15.1f %7.2f\n", transport.c_str(), nodes, request_size, reply_size,
                  1e6 * raw, 1e6 * protocol, protocol / raw);
    }
  }
  RelaxationTable();
  return 0;
}
