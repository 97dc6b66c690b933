#pragma once
// SessionNode: a Session on the network. One I/O thread poll()s every socket of the session
// (the shared port, each participant's own port, the anchor's localizer port), the calibration
// files (inotify: a new `coloc handeye solve --output` over a participant's file re-anchors that
// participant while running) and an eventfd for stop(); its timeout is the next staleness
// deadline, so nothing sleeps or polls on a timer. Outputs go to every publish target; replies
// to /coloc/get_pose go to the requester.
//
// Why its own sockets instead of fusion::OscEndpoint: one thread serves several ports, and the
// session decodes its own address space (wire.hpp). IPv4, bound to loopback unless told.
// Thread-safety: public methods may be called from any thread.

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "fusion/osc_endpoint.hpp"  // OscPeer, parse_osc_url
#include "fusion/session/session.hpp"
#include "fusion/session/wire.hpp"

namespace coloc::fusion::session {

struct SessionNodeOptions {
  std::string bind_address = "127.0.0.1";  // "0.0.0.0" = every interface
  int port = 0;                            // the shared port; 0 = any free one (see port())
  std::vector<std::string> publish;        // osc.udp://host:port targets of the outputs
  std::size_t max_packet_size = kDefaultMaxPacketSize;
  bool watch_calibrations = true;  // hot reload on a new calibration file

  void check() const;  // throws coloc::Error naming the field
};

struct SessionNodeStats {
  SessionStats session;
  WireStats wire;
  std::uint64_t untagged = 0;  // pose messages without a participant id on the shared port
  std::uint64_t sent = 0;      // datagrams sent (outputs x targets, replies)
  std::uint64_t send_errors = 0;
  std::uint64_t replies = 0;     // /coloc/get_pose requests answered
  std::uint64_t non_finite = 0;  // outputs with a NaN / inf, sent as lost (state 0)
};

// One accepted input, as it arrived (for the session log: `coloc session --log`).
struct LogRecord {
  double receive_time = 0.0;  // s, the node's monotonic clock
  std::string participant;    // empty for the anchor camera
  std::string device;         // "head", "controller/<n>", "global", "anchor"
  PoseMessage pose;           // vr frame for head / controllers, world frame otherwise
};
using LogSink = std::function<void(const LogRecord&)>;

class SessionNode {
 public:
  // Binds every port (throws coloc::Error naming the port on failure) and parses the targets.
  SessionNode(Session session, SessionNodeOptions options, LogSink log = {});
  ~SessionNode();
  SessionNode(const SessionNode&) = delete;
  SessionNode& operator=(const SessionNode&) = delete;

  void start();
  void stop();
  int port() const { return sockets_.front().port; }

  SessionNodeStats stats() const;
  ParticipantSnapshot snapshot(const std::string& id) const;
  ReloadReport reload(const std::string& id);
  // Reload reports in the order they happened (file watcher and OSC requests included).
  std::vector<ReloadReport> reloads() const;

 private:
  enum class Role : std::uint8_t { kShared, kParticipant, kAnchor };
  struct Socket {
    int fd = -1;
    int port = 0;
    Role role = Role::kShared;
    std::string participant;
  };

  void run();
  void drain(const Socket& socket);
  void handle(const Socket& socket, const OscPeer& from, const SessionMessage& m, double now,
              std::vector<Output>& out);
  void send_outputs(const std::vector<Output>& out);
  void reply(const OscPeer& to, const std::vector<Output>& out);
  void handle_file_events();
  void log(const std::string& participant, std::string device, const PoseMessage& pose, double now);

  SessionNodeOptions options_;
  LogSink log_;
  std::vector<Socket> sockets_;  // [0] is the shared port
  std::vector<OscPeer> targets_;
  std::vector<std::uint8_t> buffer_;
  int wake_fd_ = -1;
  int inotify_fd_ = -1;
  std::map<int, std::filesystem::path> watched_;  // inotify watch -> folder

  mutable std::mutex mutex_;  // guards session_, stats_ and reloads_
  Session session_;
  SessionNodeStats stats_;
  std::vector<ReloadReport> reloads_;

  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// Seconds on the node's clock (steady, arbitrary origin).
double session_clock();

}  // namespace coloc::fusion::session
