#include "fusion/osc_node.hpp"

#include <utility>

namespace coloc::fusion {

ReceiverThread::ReceiverThread(OscEndpoint& endpoint, Handler handler)
    : endpoint_(endpoint), handler_(std::move(handler)) {}

void ReceiverThread::start() {
  if (thread_.joinable()) return;
  stop_ = false;
  thread_ = std::thread([this] {
    while (!stop_) {
      if (auto packet = endpoint_.receive(-1)) handler_(*packet);
    }
  });
}

void ReceiverThread::stop() {
  if (!thread_.joinable()) return;
  stop_ = true;
  endpoint_.wake();
  thread_.join();
}

// ---------------------------------------------------------------------------------------------

PoseServer::PoseServer(PoseServerOptions options)
    : options_(std::move(options)),
      endpoint_(options_.endpoint),
      receiver_(endpoint_, [this](const OscPacket& p) { handle(p); }) {
  for (const std::string& url : options_.targets)
    endpoint_.add_target(url);
}

PoseServer::~PoseServer() {
  receiver_.stop();
}

void PoseServer::start() {
  receiver_.start();
}
void PoseServer::stop() {
  receiver_.stop();
}

void PoseServer::publish(const PoseMessage& pose) {
  {
    const std::lock_guard lock(mutex_);
    latest_ = pose;
    have_latest_ = true;
  }
  endpoint_.publish(kPoseAddress, pose, options_.bundles);
}

void PoseServer::set_latest(const PoseMessage& pose) {
  const std::lock_guard lock(mutex_);
  latest_ = pose;
  have_latest_ = true;
}

void PoseServer::handle(const OscPacket& packet) {
  for (const OscMessage& m : packet.messages) {
    if (m.address != kGetPoseAddress) continue;  // a pose sent to the server: not for us
    PoseMessage reply;
    {
      const std::lock_guard lock(mutex_);
      if (!have_latest_) {
        reply.state = 0;  // lost: nothing localized yet
      } else {
        reply = latest_;
      }
    }
    OscPeer to = packet.from;
    if (m.reply_port > 0) to.port = static_cast<std::uint16_t>(m.reply_port);
    if (endpoint_.send_to(to, encode_pose(kPoseAddress, reply, options_.bundles))) ++answered_;
  }
}

// ---------------------------------------------------------------------------------------------

FusionNode::FusionNode(FusionNodeOptions options)
    : options_(std::move(options)),
      endpoint_(options_.endpoint),
      fuser_(options_.fuser),
      global_stream_(options_.streams),
      xr_stream_(options_.streams),
      receiver_(endpoint_, [this](const OscPacket& p) { handle(p); }) {
  for (const std::string& url : options_.publish)
    endpoint_.add_target(url);
}

FusionNode::~FusionNode() {
  receiver_.stop();
}

void FusionNode::start() {
  receiver_.start();
}
void FusionNode::stop() {
  receiver_.stop();
}

FusedPose FusionNode::push_xr_locked(double time, const SE3& xr_from_head) {
  const std::uint64_t before = fuser_.stats().xr_poses;
  FusedPose out = fuser_.push_xr_pose(time, xr_from_head);
  if (fuser_.stats().xr_poses == before) return out;  // out of order: nothing new
  if (options_.on_fused) options_.on_fused(out);
  if (!endpoint_.targets().empty()) {
    const auto message = PoseMessage::from_pose(
        out.time, next_sequence_++, static_cast<std::int32_t>(out.state), out.world_from_head);
    published_ += endpoint_.publish(kFusedPoseAddress, message, options_.bundles);
  }
  return out;
}

FusedPose FusionNode::push_xr_pose(double time, const SE3& xr_from_head) {
  const std::lock_guard lock(mutex_);
  return push_xr_locked(time, xr_from_head);
}

GateDecision FusionNode::push_global_pose(double time, const SE3& world_from_head,
                                          TrackingState tracking) {
  const std::lock_guard lock(mutex_);
  return fuser_.push_global_pose(time, world_from_head, tracking);
}

FusedPose FusionNode::latest() const {
  const std::lock_guard lock(mutex_);
  return fuser_.latest();
}

FusionNodeStats FusionNode::stats() const {
  FusionNodeStats s;
  s.osc = endpoint_.stats();
  const std::lock_guard lock(mutex_);
  s.fuser = fuser_.stats();
  s.out_of_order = out_of_order_;
  s.implausible = implausible_;
  s.resyncs = resyncs_;
  s.published = published_;
  s.requests_answered = answered_;
  return s;
}

bool FusionNode::admit(StreamGuard& guard, const PoseMessage& pose, double received, bool xr) {
  switch (guard.check(pose.sequence, pose.time, received)) {
    case StreamVerdict::kAccepted:
      return true;
    case StreamVerdict::kResynced:
      // The stream moved to a new clock or sender: the fuser's history of it would reject every
      // message from now on.
      ++resyncs_;
      if (xr) {
        fuser_.restart_xr_clock();
      } else {
        fuser_.restart_global_clock();
      }
      return true;
    case StreamVerdict::kStale:
      ++out_of_order_;
      return false;
    case StreamVerdict::kImplausible:
      ++implausible_;
      return false;
  }
  return false;
}

void FusionNode::handle(const OscPacket& packet) {
  const std::lock_guard lock(mutex_);
  for (const OscMessage& m : packet.messages) {
    if (m.address == kPoseAddress) {
      if (!admit(global_stream_, m.pose, packet.received, false)) continue;
      fuser_.push_global_pose(m.pose.time, m.pose.pose(), tracking_state_from_wire(m.pose.state));
    } else if (m.address == kXrPoseAddress) {
      if (!admit(xr_stream_, m.pose, packet.received, true)) continue;
      push_xr_locked(m.pose.time, m.pose.pose());
    } else if (m.address == kGetPoseAddress) {
      const FusedPose& f = fuser_.latest();
      OscPeer to = packet.from;
      if (m.reply_port > 0) to.port = static_cast<std::uint16_t>(m.reply_port);
      const auto reply = PoseMessage::from_pose(
          f.time, next_sequence_++, static_cast<std::int32_t>(f.state), f.world_from_head);
      if (endpoint_.send_to(to, encode_pose(kFusedPoseAddress, reply, options_.bundles))) {
        ++answered_;
      }
    }
    // /coloc/fused_pose arriving here is someone else's output: ignored.
  }
}

}  // namespace coloc::fusion
