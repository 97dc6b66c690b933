#pragma once
// OscEndpoint: one UDP socket that sends and receives coloc's OSC pose messages (osc.hpp).
//
// Why our own socket instead of lo_server: liblo 0.31 binds UDP servers to every interface and
// cannot be told to bind loopback only, and we want one socket for both directions (replies to
// /coloc/get_pose come from the port the client asked) with SO_BROADCAST under our control.
// liblo still does all OSC encoding and decoding. IPv4 only.
//
// Thread-safety: receive() from one thread at a time; publish()/send_to()/wake()/stats() from
// any thread once the targets are set up (add_target is not thread-safe).

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "fusion/osc.hpp"

namespace coloc::fusion {

struct OscEndpointOptions {
  std::string bind_address = "127.0.0.1";  // loopback unless told otherwise ("0.0.0.0" = all)
  int port = 0;                            // 0 = any free port (read it back with port())
  bool broadcast = false;                  // SO_BROADCAST: allow subnet broadcast targets
  std::size_t max_packet_size = kDefaultMaxPacketSize;

  void check() const;  // throws coloc::Error naming the field
};

// An IPv4 UDP peer.
struct OscPeer {
  std::uint32_t ip = 0;  // host byte order
  std::uint16_t port = 0;
  std::string to_string() const;  // "osc.udp://a.b.c.d:port"
  bool operator==(const OscPeer&) const = default;
};

// Parses "osc.udp://host:port" (host: dotted IPv4 or a name resolved now). Throws coloc::Error
// with field "url" on anything else.
OscPeer parse_osc_url(std::string_view url);

// Counters since construction (a snapshot).
struct OscStats {
  std::uint64_t packets = 0;    // datagrams received
  std::uint64_t messages = 0;   // messages decoded and handed out
  std::uint64_t oversized = 0;  // packets larger than max_packet_size
  std::uint64_t malformed = 0;  // not OSC 1.0
  std::uint64_t unknown_address = 0;
  std::uint64_t wrong_types = 0;
  std::uint64_t invalid_values = 0;
  std::uint64_t sent = 0;  // datagrams sent
  std::uint64_t send_errors = 0;
  std::uint64_t non_finite = 0;  // poses with a NaN / inf published as lost (state 0)
  std::string last_error;        // reason of the last dropped packet, for logs
};

struct OscPacket {
  OscPeer from;
  std::vector<OscMessage> messages;  // never empty
  double received = 0.0;             // s, steady clock at arrival (plausibility of message times)
};

class OscEndpoint {
 public:
  // Binds the socket; throws coloc::Error (field "bind_address" or "port") when it cannot.
  explicit OscEndpoint(OscEndpointOptions options = {});
  ~OscEndpoint();
  OscEndpoint(const OscEndpoint&) = delete;
  OscEndpoint& operator=(const OscEndpoint&) = delete;

  int port() const { return port_; }
  const OscEndpointOptions& options() const { return options_; }

  void add_target(std::string_view url) { targets_.push_back(parse_osc_url(url)); }
  const std::vector<OscPeer>& targets() const { return targets_; }

  // Sends one pose message to every target; returns how many sends succeeded.
  std::size_t publish(std::string_view address, const PoseMessage& pose, bool as_bundle = false);
  bool send_to(const OscPeer& peer, const std::vector<std::uint8_t>& bytes);

  // Waits up to timeout_ms (< 0: forever) for a datagram, or until wake(). Bad packets are
  // counted and dropped (std::nullopt), as are timeouts and wake-ups; never throws for input.
  std::optional<OscPacket> receive(int timeout_ms);
  // Makes a blocked receive() return (from any thread); used to stop receiver threads.
  void wake();

  OscStats stats() const;

 private:
  void count_error(OscError error, const std::string& detail);

  OscEndpointOptions options_;
  int socket_ = -1;
  int wake_fd_ = -1;  // eventfd
  int port_ = 0;
  std::vector<OscPeer> targets_;
  std::vector<std::uint8_t> buffer_;

  std::atomic<std::uint64_t> packets_{0}, messages_{0}, oversized_{0}, malformed_{0},
      unknown_address_{0}, wrong_types_{0}, invalid_values_{0}, sent_{0}, send_errors_{0},
      non_finite_{0};
  mutable std::mutex error_mutex_;  // guards last_error_ only (written by the receiving thread)
  std::string last_error_;
};

}  // namespace coloc::fusion
