#include "fusion/replay.hpp"

namespace coloc::fusion {
namespace {

// Hands the global samples to a fuser in arrival order, as time goes on.
class GlobalFeed {
 public:
  explicit GlobalFeed(const std::vector<GlobalSample>& samples) : samples_(samples) {}

  // Pushes every sample that has arrived by `time` (arrival_time <= time) and not been pushed.
  template <typename Fuser>
  void deliver_until(double time, Fuser& fuser) {
    for (; next_ < samples_.size() && samples_[next_].arrival_time <= time; ++next_)
      fuser.push_global_pose(samples_[next_].exposure_time, samples_[next_].world_from_head);
  }

 private:
  const std::vector<GlobalSample>& samples_;
  std::size_t next_ = 0;
};

}  // namespace

std::vector<GlobalSample> delayed(const Trajectory& world_from_head, double latency) {
  std::vector<GlobalSample> out;
  out.reserve(world_from_head.size());
  for (const StampedPose& p : world_from_head)
    out.push_back({p.timestamp, p.timestamp + latency, p.world_from_cam, false});
  return out;
}

Trajectory replay_headset(const Trajectory& xr_from_head, const std::vector<GlobalSample>& global,
                          DriftFuser& fuser) {
  Trajectory out;
  out.reserve(xr_from_head.size());
  GlobalFeed feed(global);
  for (const StampedPose& h : xr_from_head) {
    feed.deliver_until(h.timestamp, fuser);
    out.push_back({h.timestamp, fuser.push_xr_pose(h.timestamp, h.world_from_cam).world_from_head});
  }
  return out;
}

HeadsetReplay replay_headset(const Trajectory& xr_from_head,
                             const std::vector<GlobalSample>& global, const FuserOptions& options) {
  DriftFuser fuser(options);
  HeadsetReplay r;
  r.fused = replay_headset(xr_from_head, global, fuser);
  r.stats = fuser.stats();
  return r;
}

ImuReplay replay_imu(const std::vector<ImuSample>& imu, const std::vector<GlobalSample>& global,
                     const ImuFuserOptions& options) {
  ImuFuser fuser(options);
  ImuReplay r;
  GlobalFeed feed(global);
  for (const ImuSample& s : imu) {
    feed.deliver_until(s.time, fuser);
    const FusedPose out = fuser.push_imu(s);
    // Before anchoring the integrator is in its own odometry frame: nothing to output.
    if (fuser.anchored() && out.state != FusionState::kWaiting)
      r.fused.push_back({s.time, out.world_from_head});
  }
  r.imu = fuser.stats();
  r.fuser = fuser.fuser().stats();
  return r;
}

}  // namespace coloc::fusion
