#include "fusion/osc_player.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <thread>

#include "fusion/osc_endpoint.hpp"
#include "slam/core/error.hpp"

namespace coloc::fusion {

void OscPlayOptions::check() const {
  if (targets.empty()) throw Error("at least one target is needed", {.field = "targets"});
  if (!std::isfinite(speed) || speed <= 0.0)
    throw Error("must be a finite number > 0", {.field = "speed"});
}

OscPlayStats play_poses(const std::vector<OscPlayStream>& streams, const OscPlayOptions& options,
                        const std::atomic<bool>& stop) {
  options.check();
  struct Message {
    double due;  // recording seconds
    std::size_t stream, index;
  };
  std::vector<Message> order;
  double t0 = std::numeric_limits<double>::infinity();
  for (std::size_t s = 0; s < streams.size(); ++s) {
    const OscPlayStream& stream = streams[s];
    if (stream.address != kXrPoseAddress && stream.address != kPoseAddress)
      throw Error("must be /coloc/xr_pose or /coloc/pose", {.field = "address"});
    if (!(stream.latency >= 0.0 && std::isfinite(stream.latency)))
      throw Error("must be a finite number of seconds >= 0", {.field = "latency"});
    for (std::size_t i = 0; i < stream.poses.size(); ++i) {
      order.push_back({stream.poses[i].timestamp + stream.latency, s, i});
      t0 = std::min(t0, stream.poses[i].timestamp);
    }
  }
  // By send time; ties in stream order (a headset pose before the global pose of its instant).
  std::stable_sort(order.begin(), order.end(),
                   [](const Message& a, const Message& b) { return a.due < b.due; });
  OscEndpoint endpoint;
  for (const std::string& url : options.targets)
    endpoint.add_target(url);
  OscPlayStats stats;
  using Clock = std::chrono::steady_clock;
  const Clock::time_point start = Clock::now();
  for (const Message& m : order) {
    if (stop.load()) {
      stats.stopped = true;
      break;
    }
    // A device's clock: each message leaves at its own time, whatever the sends before cost.
    std::this_thread::sleep_until(start +
                                  std::chrono::duration_cast<Clock::duration>(
                                      std::chrono::duration<double>((m.due - t0) / options.speed)));
    const OscPlayStream& stream = streams[m.stream];
    const auto& pose = stream.poses[m.index];
    const PoseMessage message = PoseMessage::from_pose(
        pose.timestamp, static_cast<std::int32_t>(m.index), 1, pose.world_from_cam);
    if (endpoint.publish(stream.address, message) == endpoint.targets().size()) {
      ++stats.sent;
    } else {
      ++stats.send_errors;
    }
  }
  return stats;
}

}  // namespace coloc::fusion
