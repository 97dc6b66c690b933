#pragma once
// Sends recorded poses over OSC at the pace they were recorded, as the device that made them
// would: `coloc fuse play` feeds a headset recording (xr_from_head, /coloc/xr_pose) to a fusion
// node, so a node can be tried end to end without the headset.
#include <atomic>
#include <string>
#include <vector>

#include "fusion/osc.hpp"
#include "slam/core/trajectory.hpp"

namespace coloc::fusion {

struct OscPlayOptions {
  std::string address = std::string(kXrPoseAddress);  // /coloc/xr_pose, or /coloc/pose
  std::vector<std::string> targets;                   // "osc.udp://host:port", at least one
  double speed = 1.0;                                 // 2 = twice as fast as recorded
  void check() const;                                 // throws coloc::Error naming the field
};

struct OscPlayStats {
  std::size_t sent = 0;  // poses sent (to every target)
  std::size_t send_errors = 0;
  bool stopped = false;  // `stop` ended the play before the last pose
};

// Sends pose i at (t_i - t_0) / speed seconds after the first, each message stamped with its
// recorded time, sequence i, state tracking. Returns at the end, or soon after `stop` is set.
OscPlayStats play_poses(const Trajectory& poses, const OscPlayOptions& options,
                        const std::atomic<bool>& stop);

}  // namespace coloc::fusion
