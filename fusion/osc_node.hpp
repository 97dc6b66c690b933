#pragma once
// The two OSC roles of coloc (address space in osc.hpp and the README):
//
//   PoseServer  the localizer side: broadcast mode pushes /coloc/pose to a list of targets
//               (unicast and/or a subnet broadcast address); on-demand mode answers
//               /coloc/get_pose with the latest pose, sent to the requester.
//   FusionNode  the fuser: /coloc/pose (global) and /coloc/xr_pose (headset) in, fused poses
//               out as /coloc/fused_pose to its targets and on /coloc/get_pose.
//
// Each owns an OscEndpoint and one receiver thread, started by start() and joined by stop() or
// the destructor; the thread blocks in poll() and is woken through an eventfd (no sleeping).
// Public methods are thread-safe.

#include <atomic>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "fusion/fuser.hpp"
#include "fusion/osc.hpp"
#include "fusion/osc_endpoint.hpp"
#include "fusion/stream_guard.hpp"

namespace coloc::fusion {

// Runs handler(packet) for every packet received on an endpoint, on its own thread.
class ReceiverThread {
 public:
  using Handler = std::function<void(const OscPacket&)>;
  ReceiverThread(OscEndpoint& endpoint, Handler handler);
  ~ReceiverThread() { stop(); }
  ReceiverThread(const ReceiverThread&) = delete;
  ReceiverThread& operator=(const ReceiverThread&) = delete;

  void start();
  void stop();
  bool running() const { return thread_.joinable(); }

 private:
  OscEndpoint& endpoint_;
  Handler handler_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

struct PoseServerOptions {
  OscEndpointOptions endpoint;
  std::vector<std::string> targets;  // osc.udp://host:port, unicast or broadcast addresses
  bool bundles = false;              // wrap each pose in a bundle timetagged with its time
};

class PoseServer {
 public:
  explicit PoseServer(PoseServerOptions options);  // binds and parses targets; throws Error
  ~PoseServer();

  void start();  // answers /coloc/get_pose from now on
  void stop();
  int port() const { return endpoint_.port(); }

  // Broadcast mode: sends /coloc/pose to every target; keeps it for on-demand requests.
  void publish(const PoseMessage& pose);
  // On-demand mode only: the pose /coloc/get_pose answers with from now on, sent to no target
  // (a localizer's lost frame: state 0, its time, the last pose it had).
  void set_latest(const PoseMessage& pose);
  OscStats stats() const { return endpoint_.stats(); }
  std::uint64_t requests_answered() const { return answered_; }

 private:
  void handle(const OscPacket& packet);

  PoseServerOptions options_;
  OscEndpoint endpoint_;
  mutable std::mutex mutex_;  // guards latest_ (publisher thread vs receiver thread)
  PoseMessage latest_;
  bool have_latest_ = false;
  std::atomic<std::uint64_t> answered_{0};
  ReceiverThread receiver_;
};

struct FusionNodeOptions {
  FuserOptions fuser;
  OscEndpointOptions endpoint;
  std::vector<std::string> publish;  // targets of /coloc/fused_pose
  bool bundles = false;
  StreamGuardOptions streams;  // plausibility of each incoming stream (stream_guard.hpp)
  // Sees each new fused pose (one per accepted headset pose), on the thread that pushed it and
  // under the node's lock: keep it short (`coloc fuse --listen --out` appends a line to a file).
  std::function<void(const FusedPose&)> on_fused;
};

struct FusionNodeStats {
  FuserStats fuser;
  OscStats osc;
  std::uint64_t out_of_order = 0;  // OSC messages dropped as stale (older sequence and time)
  std::uint64_t implausible = 0;   // OSC messages dropped as out of line (time or sequence jump)
  std::uint64_t resyncs = 0;       // streams re-anchored (restarted sender, clock step)
  std::uint64_t published = 0;     // /coloc/fused_pose messages sent (per target)
  std::uint64_t requests_answered = 0;
};

class FusionNode {
 public:
  explicit FusionNode(FusionNodeOptions options);  // binds and parses targets; throws Error
  ~FusionNode();

  void start();  // OSC input from now on
  void stop();
  bool running() const { return receiver_.running(); }
  int port() const { return endpoint_.port(); }

  // Direct input (engine plugins). push_xr_pose also publishes the fused pose to the targets.
  FusedPose push_xr_pose(double time, const SE3& xr_from_head);
  GateDecision push_global_pose(double time, const SE3& world_from_head, TrackingState tracking);

  FusedPose latest() const;
  FusionNodeStats stats() const;

  // What the receiver thread does with one packet (public so tests can drive it directly).
  void handle(const OscPacket& packet);

 private:
  FusedPose push_xr_locked(double time, const SE3& xr_from_head);
  // Passes one stream's message through its guard; false = dropped (counted).
  bool admit(StreamGuard& guard, const PoseMessage& pose, double received, bool xr);

  FusionNodeOptions options_;
  OscEndpoint endpoint_;
  mutable std::mutex mutex_;  // guards the fuser and the sequence state below
  DriftFuser fuser_;
  StreamGuard global_stream_;
  StreamGuard xr_stream_;
  std::int32_t next_sequence_ = 0;
  std::uint64_t out_of_order_ = 0;
  std::uint64_t implausible_ = 0;
  std::uint64_t resyncs_ = 0;
  std::uint64_t published_ = 0;
  std::uint64_t answered_ = 0;
  ReceiverThread receiver_;
};

}  // namespace coloc::fusion
