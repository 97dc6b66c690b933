#include "fusion/session/node.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <spdlog/spdlog.h>
#include <sys/eventfd.h>
#include <sys/inotify.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <set>

#include "slam/core/error.hpp"

namespace coloc::fusion::session {
namespace {

sockaddr_in to_sockaddr(std::uint32_t ip, int port) {
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(ip);
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  return a;
}

std::uint32_t bind_ip(const std::string& address) {
  if (address == "localhost") return INADDR_LOOPBACK;
  in_addr a{};
  if (inet_pton(AF_INET, address.c_str(), &a) != 1) {
    throw Error("'" + address + "' is not a dotted IPv4 address",
                ErrorContext{.field = "bind_address"});
  }
  return ntohl(a.s_addr);
}

// A bound, non-blocking UDP socket; returns the fd and the port it got.
std::pair<int, int> open_socket(std::uint32_t ip, int port, const std::string& what) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (fd < 0) throw Error(std::string("cannot create a UDP socket: ") + std::strerror(errno));
  const sockaddr_in a = to_sockaddr(ip, port);
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&a), sizeof(a)) != 0) {
    const std::string why = std::strerror(errno);
    ::close(fd);
    throw Error("cannot bind UDP port " + std::to_string(port) + ": " + why,
                ErrorContext{.field = what});
  }
  sockaddr_in bound{};
  socklen_t length = sizeof(bound);
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&bound), &length);
  return {fd, ntohs(bound.sin_port)};
}

std::string controller_device(int index) {
  return "controller/" + std::to_string(index);
}

}  // namespace

double session_clock() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

void SessionNodeOptions::check() const {
  if (port < 0 || port > 65535) throw Error("must be in 0..65535", ErrorContext{.field = "port"});
  if (max_packet_size < 16 || max_packet_size > 65507) {
    throw Error("must be in 16..65507 bytes", ErrorContext{.field = "max_packet_size"});
  }
}

SessionNode::SessionNode(Session session, SessionNodeOptions options, LogSink log)
    : options_(std::move(options)), log_(std::move(log)), session_(std::move(session)) {
  options_.check();
  for (const std::string& url : options_.publish)
    targets_.push_back(parse_osc_url(url));
  const std::uint32_t ip = bind_ip(options_.bind_address);
  const auto add = [&](int port, Role role, const std::string& participant,
                       const std::string& field) {
    const auto [fd, bound] = open_socket(ip, port, field);
    sockets_.push_back({fd, bound, role, participant});
  };
  try {
    add(options_.port, Role::kShared, "", "port");
    const SessionConfig& c = session_.config();
    if (c.anchor.mode == AnchorMode::kLocalize) {
      add(c.anchor.localize_port, Role::kAnchor, "", "anchor.localize.port");
    }
    for (std::size_t i = 0; i < c.participants.size(); ++i) {
      const ParticipantConfig& p = c.participants[i];
      if (p.port > 0)
        add(p.port, Role::kParticipant, p.id, "participants[" + std::to_string(i) + "].port");
    }
    wake_fd_ = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
    if (wake_fd_ < 0) throw Error(std::string("cannot create an eventfd: ") + std::strerror(errno));
  } catch (...) {
    for (const Socket& s : sockets_)
      ::close(s.fd);
    throw;
  }
  if (options_.watch_calibrations) {
    inotify_fd_ = ::inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
    std::set<std::filesystem::path> folders;
    for (const ParticipantConfig& p : session_.config().participants)
      folders.insert(p.calibration.parent_path().empty() ? "." : p.calibration.parent_path());
    for (const auto& folder : folders) {
      // Both an in-place write (close) and an atomic rename over the file count.
      const int wd = inotify_fd_ < 0 ? -1
                                     : ::inotify_add_watch(inotify_fd_, folder.c_str(),
                                                           IN_CLOSE_WRITE | IN_MOVED_TO);
      if (wd < 0) {
        spdlog::warn("session: cannot watch {} for new calibrations: {}", folder.string(),
                     std::strerror(errno));
        continue;
      }
      watched_.emplace(wd, folder);
    }
  }
  buffer_.resize(options_.max_packet_size + 1);
}

SessionNode::~SessionNode() {
  stop();
  for (const Socket& s : sockets_)
    ::close(s.fd);
  if (wake_fd_ >= 0) ::close(wake_fd_);
  if (inotify_fd_ >= 0) ::close(inotify_fd_);
}

void SessionNode::start() {
  if (thread_.joinable()) return;
  stop_ = false;
  thread_ = std::thread([this] { run(); });
}

void SessionNode::stop() {
  if (!thread_.joinable()) return;
  stop_ = true;
  const std::uint64_t one = 1;
  [[maybe_unused]] const ssize_t n = ::write(wake_fd_, &one, sizeof(one));
  thread_.join();
}

void SessionNode::run() {
  std::vector<pollfd> fds;
  for (const Socket& s : sockets_)
    fds.push_back({s.fd, POLLIN, 0});
  fds.push_back({wake_fd_, POLLIN, 0});
  fds.push_back({inotify_fd_, POLLIN, 0});  // fd -1 is ignored by poll
  while (!stop_) {
    double deadline = 0.0;
    {
      const std::lock_guard lock(mutex_);
      deadline = session_.next_deadline();
    }
    const double wait = deadline - session_clock();
    const int timeout_ms =
        std::isinf(wait) ? -1 : static_cast<int>(std::clamp(std::ceil(wait * 1e3), 0.0, 6e4));
    if (::poll(fds.data(), fds.size(), timeout_ms) < 0 && errno != EINTR) break;
    for (std::size_t i = 0; i < sockets_.size(); ++i) {
      if (fds[i].revents & POLLIN) drain(sockets_[i]);
    }
    if (fds[sockets_.size() + 1].revents & POLLIN) handle_file_events();
    std::vector<Output> out;
    {
      const std::lock_guard lock(mutex_);
      session_.tick(session_clock(), out);
    }
    send_outputs(out);
  }
}

void SessionNode::drain(const Socket& socket) {
  for (;;) {
    sockaddr_in from{};
    socklen_t length = sizeof(from);
    const ssize_t n = ::recvfrom(socket.fd, buffer_.data(), buffer_.size(), MSG_TRUNC,
                                 reinterpret_cast<sockaddr*>(&from), &length);
    if (n < 0) return;  // EAGAIN: drained (or an ICMP error reported on the socket)
    const double now = session_clock();
    const WireResult decoded = decode_session_packet(buffer_.data(), static_cast<std::size_t>(n),
                                                     options_.max_packet_size);
    const OscPeer peer{ntohl(from.sin_addr.s_addr), ntohs(from.sin_port)};
    std::vector<Output> out;
    {
      const std::lock_guard lock(mutex_);
      count(stats_.wire, decoded);
      for (const SessionMessage& m : decoded.messages)
        handle(socket, peer, m, now, out);
    }
    send_outputs(out);
  }
}

// Under mutex_. Replies are sent from here; broadcast outputs are appended to `out`.
void SessionNode::handle(const Socket& socket, const OscPeer& from, const SessionMessage& m,
                         double now, std::vector<Output>& out) {
  if (socket.role == Role::kAnchor) {
    if (m.kind == MessageKind::kGlobal) {
      session_.push_anchor(m.pose);
      log("", "anchor", m.pose, now);
    }
    return;
  }
  std::string id = m.participant.empty() ? socket.participant : m.participant;
  const bool pose = m.kind == MessageKind::kHead || m.kind == MessageKind::kController ||
                    m.kind == MessageKind::kGlobal;
  if (pose && id.empty()) {
    ++stats_.untagged;  // a plain pose on the shared port: whose is it?
    return;
  }
  switch (m.kind) {
    case MessageKind::kHead:
      session_.push_head(id, m.pose, now, out);
      log(id, "head", m.pose, now);
      break;
    case MessageKind::kController:
      session_.push_controller(id, m.controller, m.pose, now, out);
      log(id, controller_device(m.controller), m.pose, now);
      break;
    case MessageKind::kGlobal:
      session_.push_global(id, m.pose, now);
      log(id, "global", m.pose, now);
      break;
    case MessageKind::kGetPose: {
      std::vector<Output> current;
      if (!session_.current(m.participant, current)) break;
      OscPeer to = from;
      if (m.reply_port > 0) to.port = static_cast<std::uint16_t>(m.reply_port);
      reply(to, current);
      break;
    }
    case MessageKind::kReload:
      reloads_.push_back(session_.reload(m.participant));
      break;
  }
}

void SessionNode::log(const std::string& participant, std::string device, const PoseMessage& pose,
                      double now) {
  if (log_) log_(LogRecord{now, participant, std::move(device), pose});
}

void SessionNode::send_outputs(const std::vector<Output>& out) {
  if (out.empty() || targets_.empty()) return;
  std::uint64_t sent = 0, errors = 0, non_finite = 0;
  for (const Output& o : out) {
    non_finite += finite_message(o.pose) ? 0 : 1;
    const std::vector<std::uint8_t> bytes = encode_pose(o.address, o.pose);
    for (const OscPeer& peer : targets_) {
      const sockaddr_in a = to_sockaddr(peer.ip, peer.port);
      const ssize_t n = ::sendto(sockets_.front().fd, bytes.data(), bytes.size(), 0,
                                 reinterpret_cast<const sockaddr*>(&a), sizeof(a));
      (n == static_cast<ssize_t>(bytes.size()) ? sent : errors) += 1;
    }
  }
  const std::lock_guard lock(mutex_);
  stats_.sent += sent;
  stats_.send_errors += errors;
  stats_.non_finite += non_finite;
}

// Under mutex_ (called from handle()).
void SessionNode::reply(const OscPeer& to, const std::vector<Output>& out) {
  const sockaddr_in a = to_sockaddr(to.ip, to.port);
  for (const Output& o : out) {
    stats_.non_finite += finite_message(o.pose) ? 0 : 1;
    const std::vector<std::uint8_t> bytes = encode_pose(o.address, o.pose);
    const ssize_t n = ::sendto(sockets_.front().fd, bytes.data(), bytes.size(), 0,
                               reinterpret_cast<const sockaddr*>(&a), sizeof(a));
    (n == static_cast<ssize_t>(bytes.size()) ? stats_.sent : stats_.send_errors) += 1;
  }
  ++stats_.replies;
}

void SessionNode::handle_file_events() {
  alignas(inotify_event) std::array<char, 4096> events{};
  std::set<std::string> changed;
  for (;;) {
    const ssize_t n = ::read(inotify_fd_, events.data(), events.size());
    if (n <= 0) break;
    for (ssize_t at = 0; at < n;) {
      const auto* e = reinterpret_cast<const inotify_event*>(events.data() + at);
      at += static_cast<ssize_t>(sizeof(inotify_event) + e->len);
      const auto folder = watched_.find(e->wd);
      if (folder == watched_.end() || e->len == 0) continue;
      const std::lock_guard lock(mutex_);
      if (const ParticipantConfig* p =
              session_.participant_by_calibration(folder->second / e->name)) {
        changed.insert(p->id);
      }
    }
  }
  for (const std::string& id : changed) {
    const std::lock_guard lock(mutex_);
    reloads_.push_back(session_.reload(id));
  }
}

SessionNodeStats SessionNode::stats() const {
  const std::lock_guard lock(mutex_);
  SessionNodeStats s = stats_;
  s.session = session_.stats();
  return s;
}

ParticipantSnapshot SessionNode::snapshot(const std::string& id) const {
  const std::lock_guard lock(mutex_);
  return session_.snapshot(id);
}

ReloadReport SessionNode::reload(const std::string& id) {
  const std::lock_guard lock(mutex_);
  reloads_.push_back(session_.reload(id));
  return reloads_.back();
}

std::vector<ReloadReport> SessionNode::reloads() const {
  const std::lock_guard lock(mutex_);
  return reloads_;
}

}  // namespace coloc::fusion::session
