#include "fusion/osc_player.hpp"

#include <chrono>
#include <cmath>
#include <thread>

#include "fusion/osc_endpoint.hpp"
#include "slam/core/error.hpp"

namespace coloc::fusion {

void OscPlayOptions::check() const {
  if (address != kXrPoseAddress && address != kPoseAddress)
    throw Error("must be /coloc/xr_pose or /coloc/pose", {.field = "address"});
  if (targets.empty()) throw Error("at least one target is needed", {.field = "targets"});
  if (!std::isfinite(speed) || speed <= 0.0)
    throw Error("must be a finite number > 0", {.field = "speed"});
}

OscPlayStats play_poses(const Trajectory& poses, const OscPlayOptions& options,
                        const std::atomic<bool>& stop) {
  options.check();
  OscEndpoint endpoint;
  for (const std::string& url : options.targets)
    endpoint.add_target(url);
  OscPlayStats stats;
  if (poses.empty()) return stats;
  using Clock = std::chrono::steady_clock;
  const Clock::time_point start = Clock::now();
  const double t0 = poses.front().timestamp;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (stop.load()) {
      stats.stopped = true;
      break;
    }
    // A device's clock: each pose leaves at its own time, whatever the sends before it cost.
    const double due = (poses[i].timestamp - t0) / options.speed;
    std::this_thread::sleep_until(
        start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(due)));
    const PoseMessage message = PoseMessage::from_pose(
        poses[i].timestamp, static_cast<std::int32_t>(i), 1, poses[i].world_from_cam);
    const std::size_t delivered = endpoint.publish(options.address, message);
    if (delivered == endpoint.targets().size()) {
      ++stats.sent;
    } else {
      ++stats.send_errors;
    }
  }
  return stats;
}

}  // namespace coloc::fusion
