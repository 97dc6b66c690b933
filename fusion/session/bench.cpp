#include "fusion/session/bench.hpp"

#include <arpa/inet.h>
#include <lo/lo.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <thread>

#include "registration/handeye/io.hpp"
#include "slam/core/error.hpp"

namespace coloc::fusion::session {
namespace {

// A loopback UDP receiver with a large buffer (so the kernel does not drop a burst).
struct Receiver {
  int fd = -1;
  int port = 0;
  Receiver() {
    fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    const int size = 8 << 20;
    ::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &size, sizeof(size));
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (fd < 0 || ::bind(fd, reinterpret_cast<const sockaddr*>(&a), sizeof(a)) != 0) {
      throw Error(std::string("bench: cannot bind a receiver: ") + std::strerror(errno));
    }
    socklen_t length = sizeof(a);
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &length);
    port = ntohs(a.sin_port);
  }
  ~Receiver() { ::close(fd); }
  Receiver(const Receiver&) = delete;
  Receiver& operator=(const Receiver&) = delete;
};

// The time argument of a received output (its first argument), or a negative value.
double output_time(std::uint8_t* data, std::size_t size) {
  int code = 0;
  lo_message m = lo_message_deserialise(data, size, &code);
  if (m == nullptr) return -1.0;
  double t = -1.0;
  if (lo_message_get_argc(m) >= 1 && lo_message_get_types(m)[0] == 'd') {
    std::memcpy(&t, static_cast<const void*>(lo_message_get_argv(m)[0]), sizeof(t));
  }
  lo_message_free(m);
  return t;
}

SessionConfig bench_config(const LatencyBenchOptions& o, const std::filesystem::path& dir) {
  SessionConfig config;
  for (int k = 0; k < o.participants; ++k) {
    ParticipantConfig p;
    p.id = "user" + std::to_string(k);
    p.calibration = dir / (p.id + ".yaml");
    p.controllers = o.controllers;
    registration::handeye::write_calibration(
        p.calibration, {SE3(), SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(k, 0, 1)), 1.0});
    config.participants.push_back(p);
  }
  return config;
}

// Sends every participant's poses once per tick, paced at the rate; returns messages sent.
std::uint64_t send_poses(const LatencyBenchOptions& o, int port) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  to.sin_port = htons(static_cast<std::uint16_t>(port));
  const auto ticks = static_cast<int>(o.seconds * o.rate);
  const auto start = std::chrono::steady_clock::now();
  std::uint64_t sent = 0;
  for (int i = 0; i < ticks; ++i) {
    std::this_thread::sleep_until(start + std::chrono::duration<double>(i / o.rate));
    for (int k = 0; k < o.participants; ++k) {
      const std::string id = "user" + std::to_string(k);
      for (int n = -1; n < o.controllers; ++n) {
        const PoseMessage pose = PoseMessage::from_pose(session_clock(), i, 1, SE3());
        const auto bytes = n < 0 ? encode_head(pose, id) : encode_controller(pose, n, id);
        sent += ::sendto(fd, bytes.data(), bytes.size(), 0, reinterpret_cast<const sockaddr*>(&to),
                         sizeof(to)) == static_cast<ssize_t>(bytes.size());
      }
    }
  }
  ::close(fd);
  return sent;
}

}  // namespace

void LatencyBenchOptions::check() const {
  const auto require = [](bool ok, const char* field) {
    if (!ok) throw Error("out of range", ErrorContext{.field = field});
  };
  require(participants >= 1 && participants <= 64, "participants");
  require(rate > 0.0 && rate <= 2000.0, "rate");
  require(controllers >= 0 && controllers <= kMaxControllers, "controllers");
  require(seconds > 0.0, "seconds");
}

LatencyBenchReport bench_session_latency(const LatencyBenchOptions& o) {
  o.check();
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("coloc_bench_session_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  Receiver receiver;
  SessionNodeOptions options;
  options.publish = {"osc.udp://127.0.0.1:" + std::to_string(receiver.port)};
  options.watch_calibrations = false;
  SessionNode node(Session(bench_config(o, dir)), options);
  node.start();
  std::atomic<bool> done{false};
  std::vector<double> latencies;
  std::thread listen([&] {
    std::vector<std::uint8_t> buffer(2048);
    pollfd fd{receiver.fd, POLLIN, 0};
    // After the sender finishes, wait 200 ms more for stragglers.
    while (::poll(&fd, 1, done ? 200 : 1000) > 0 || !done) {
      const ssize_t n = ::recv(receiver.fd, buffer.data(), buffer.size(), MSG_DONTWAIT);
      if (n <= 0) continue;
      const double now = session_clock();
      const double t = output_time(buffer.data(), static_cast<std::size_t>(n));
      if (t >= 0.0) latencies.push_back(now - t);
    }
  });
  const auto start = std::chrono::steady_clock::now();
  LatencyBenchReport r;
  r.sent = send_poses(o, node.port());
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  done = true;
  listen.join();
  node.stop();
  std::filesystem::remove_all(dir);
  r.node = node.stats();
  const SessionStats& s = r.node.session;
  r.published = s.published;
  r.received = latencies.size();
  r.counted = r.node.wire.malformed + r.node.wire.oversized + r.node.wire.unknown_address +
              r.node.wire.wrong_types + r.node.wire.invalid_values + r.node.untagged +
              s.unknown_participant + s.bad_controller + s.out_of_order + s.implausible +
              s.waiting_for_anchor;
  r.lost = r.sent > r.received + r.counted ? r.sent - r.received - r.counted : 0;
  r.messages_per_second = static_cast<double>(r.sent) / wall;
  if (!latencies.empty()) {
    std::sort(latencies.begin(), latencies.end());
    const auto at = [&](double q) {
      return 1e3 *
             latencies[static_cast<std::size_t>(q * static_cast<double>(latencies.size() - 1))];
    };
    r.median_ms = at(0.5);
    r.p99_ms = at(0.99);
    r.max_ms = 1e3 * latencies.back();
  }
  return r;
}

}  // namespace coloc::fusion::session
