#include "fusion/osc_endpoint.hpp"

#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <mutex>
#include <string>

#include "slam/core/error.hpp"

namespace coloc::fusion {
namespace {

sockaddr_in to_sockaddr(const OscPeer& peer) {
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(peer.ip);
  a.sin_port = htons(peer.port);
  return a;
}

std::optional<std::uint32_t> resolve_ipv4(const std::string& host) {
  in_addr a{};
  if (inet_pton(AF_INET, host.c_str(), &a) == 1) return ntohl(a.s_addr);
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* found = nullptr;
  if (getaddrinfo(host.c_str(), nullptr, &hints, &found) != 0 || found == nullptr) {
    return std::nullopt;
  }
  const auto ip = ntohl(reinterpret_cast<const sockaddr_in*>(found->ai_addr)->sin_addr.s_addr);
  freeaddrinfo(found);
  return ip;
}

}  // namespace

void OscEndpointOptions::check() const {
  if (port < 0 || port > 65535) {
    throw Error("must be in 0..65535, got " + std::to_string(port), ErrorContext{.field = "port"});
  }
  if (max_packet_size < 16 || max_packet_size > 65507) {
    throw Error("must be in 16..65507 bytes", ErrorContext{.field = "max_packet_size"});
  }
}

std::string OscPeer::to_string() const {
  in_addr a{};
  a.s_addr = htonl(ip);
  char text[INET_ADDRSTRLEN] = {};
  inet_ntop(AF_INET, &a, text, sizeof(text));
  return "osc.udp://" + std::string(text) + ":" + std::to_string(port);
}

OscPeer parse_osc_url(std::string_view url) {
  constexpr std::string_view kScheme = "osc.udp://";
  const auto fail = [&](const std::string& why) {
    throw Error("'" + std::string(url) + "': " + why + " (expected osc.udp://host:port)",
                ErrorContext{.field = "url"});
  };
  if (url.substr(0, kScheme.size()) != kScheme) fail("unsupported scheme");
  std::string_view rest = url.substr(kScheme.size());
  if (!rest.empty() && rest.back() == '/') rest.remove_suffix(1);
  const auto colon = rest.rfind(':');
  if (colon == std::string_view::npos || colon == 0) fail("missing host or port");
  const std::string host(rest.substr(0, colon));
  const std::string port_text(rest.substr(colon + 1));
  int port = 0;
  try {
    std::size_t used = 0;
    port = std::stoi(port_text, &used);
    if (used != port_text.size()) fail("port is not a number");
  } catch (const std::logic_error&) {
    fail("port is not a number");
  }
  if (port <= 0 || port > 65535) fail("port out of range");
  const auto ip = resolve_ipv4(host);
  if (!ip) fail("cannot resolve host '" + host + "'");
  return {*ip, static_cast<std::uint16_t>(port)};
}

OscEndpoint::OscEndpoint(OscEndpointOptions options) : options_(std::move(options)) {
  options_.check();
  const auto ip = resolve_ipv4(options_.bind_address);
  if (!ip) {
    throw Error("cannot resolve '" + options_.bind_address + "'",
                ErrorContext{.field = "bind_address"});
  }
  socket_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  wake_fd_ = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (socket_ < 0 || wake_fd_ < 0) {
    const std::string why = std::strerror(errno);
    if (socket_ >= 0) ::close(socket_);
    if (wake_fd_ >= 0) ::close(wake_fd_);
    throw Error("cannot create a UDP socket: " + why);
  }
  const int on = 1;
  if (options_.broadcast) ::setsockopt(socket_, SOL_SOCKET, SO_BROADCAST, &on, sizeof(on));
  const sockaddr_in a = to_sockaddr({*ip, static_cast<std::uint16_t>(options_.port)});
  if (::bind(socket_, reinterpret_cast<const sockaddr*>(&a), sizeof(a)) != 0) {
    const std::string why = std::strerror(errno);
    ::close(socket_);
    ::close(wake_fd_);
    throw Error("cannot bind UDP " + options_.bind_address + ":" + std::to_string(options_.port) +
                    ": " + why,
                ErrorContext{.field = "port"});
  }
  sockaddr_in bound{};
  socklen_t length = sizeof(bound);
  ::getsockname(socket_, reinterpret_cast<sockaddr*>(&bound), &length);
  port_ = ntohs(bound.sin_port);
  // One byte more than allowed, so an oversized datagram is recognized (MSG_TRUNC reports it).
  buffer_.resize(options_.max_packet_size + 1);
}

OscEndpoint::~OscEndpoint() {
  ::close(socket_);
  ::close(wake_fd_);
}

bool OscEndpoint::send_to(const OscPeer& peer, const std::vector<std::uint8_t>& bytes) {
  const sockaddr_in a = to_sockaddr(peer);
  const ssize_t n = ::sendto(socket_, bytes.data(), bytes.size(), 0,
                             reinterpret_cast<const sockaddr*>(&a), sizeof(a));
  if (n != static_cast<ssize_t>(bytes.size())) {
    ++send_errors_;
    return false;
  }
  ++sent_;
  return true;
}

std::size_t OscEndpoint::publish(std::string_view address, const PoseMessage& pose,
                                 bool as_bundle) {
  if (targets_.empty()) return 0;
  if (!finite_message(pose)) ++non_finite_;
  const std::vector<std::uint8_t> bytes = encode_pose(address, pose, as_bundle);
  std::size_t ok = 0;
  for (const OscPeer& peer : targets_)
    ok += send_to(peer, bytes) ? 1 : 0;
  return ok;
}

void OscEndpoint::wake() {
  const std::uint64_t one = 1;
  [[maybe_unused]] const ssize_t n = ::write(wake_fd_, &one, sizeof(one));
}

void OscEndpoint::count_error(OscError error, const std::string& detail) {
  switch (error) {
    case OscError::kNone:
      return;
    case OscError::kOversized:
      ++oversized_;
      break;
    case OscError::kMalformed:
      ++malformed_;
      break;
    case OscError::kUnknownAddress:
      ++unknown_address_;
      break;
    case OscError::kWrongTypes:
      ++wrong_types_;
      break;
    case OscError::kInvalidValue:
      ++invalid_values_;
      break;
  }
  const std::lock_guard lock(error_mutex_);
  last_error_ = detail;
}

std::optional<OscPacket> OscEndpoint::receive(int timeout_ms) {
  pollfd fds[2] = {{socket_, POLLIN, 0}, {wake_fd_, POLLIN, 0}};
  if (::poll(fds, 2, timeout_ms) <= 0) return std::nullopt;
  if (fds[1].revents & POLLIN) {
    std::uint64_t count = 0;
    [[maybe_unused]] const ssize_t n = ::read(wake_fd_, &count, sizeof(count));
    return std::nullopt;
  }
  sockaddr_in from{};
  socklen_t length = sizeof(from);
  const ssize_t n = ::recvfrom(socket_, buffer_.data(), buffer_.size(), MSG_TRUNC | MSG_DONTWAIT,
                               reinterpret_cast<sockaddr*>(&from), &length);
  if (n < 0) return std::nullopt;  // e.g. ICMP port unreachable reported on this socket
  ++packets_;
  const auto size = static_cast<std::size_t>(n);
  // MSG_TRUNC returns the real datagram size even when it did not fit in the buffer.
  if (size > options_.max_packet_size) {
    count_error(OscError::kOversized, "packet of " + std::to_string(size) + " bytes exceeds " +
                                          std::to_string(options_.max_packet_size));
    return std::nullopt;
  }
  const OscDecodeResult decoded = decode_packet(buffer_.data(), size, options_.max_packet_size);
  count_error(decoded.error, decoded.detail);
  if (decoded.messages.empty()) return std::nullopt;
  messages_ += decoded.messages.size();
  const double received =
      std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
  return OscPacket{{ntohl(from.sin_addr.s_addr), ntohs(from.sin_port)}, decoded.messages, received};
}

OscStats OscEndpoint::stats() const {
  OscStats s;
  s.packets = packets_;
  s.messages = messages_;
  s.oversized = oversized_;
  s.malformed = malformed_;
  s.unknown_address = unknown_address_;
  s.wrong_types = wrong_types_;
  s.invalid_values = invalid_values_;
  s.sent = sent_;
  s.send_errors = send_errors_;
  s.non_finite = non_finite_;
  const std::lock_guard lock(error_mutex_);
  s.last_error = last_error_;
  return s;
}

}  // namespace coloc::fusion
