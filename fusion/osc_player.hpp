#pragma once
// Sends recorded poses over OSC at the pace they were recorded, as the devices that made them
// would: `coloc fuse play` feeds a headset recording (xr_from_head, /coloc/xr_pose), and
// optionally a localizer's global poses (/coloc/pose) delivered with its latency, to a fusion
// node, so a node can be tried end to end without the headset or the camera. Several streams
// play from one thread in one order (by send time), so a receiver on loopback sees the same
// sequence of messages however busy the machine is; only the pace depends on the clock.
#include <atomic>
#include <string>
#include <vector>

#include "fusion/osc.hpp"
#include "slam/core/trajectory.hpp"

namespace coloc::fusion {

struct OscPlayStream {
  Trajectory poses;                                   // stamped on the recording's clock
  std::string address = std::string(kXrPoseAddress);  // /coloc/xr_pose or /coloc/pose
  double latency = 0.0;  // seconds: each pose is sent this long after its stamp (>= 0)
};

struct OscPlayOptions {
  std::vector<std::string> targets;  // "osc.udp://host:port", at least one
  double speed = 1.0;                // 2 = twice as fast as recorded
  void check() const;                // throws coloc::Error naming the field
};

struct OscPlayStats {
  std::size_t sent = 0;  // messages sent (to every target)
  std::size_t send_errors = 0;
  bool stopped = false;  // `stop` ended the play before the last message
};

// Sends every pose of every stream at (stamp + latency - t0) / speed seconds after the start
// (t0: the earliest stamp), stamped with its recorded time, sequence = its index in its stream,
// state tracking. Returns at the end, or soon after `stop` is set. Throws coloc::Error naming
// the field for a bad address, latency or target.
OscPlayStats play_poses(const std::vector<OscPlayStream>& streams, const OscPlayOptions& options,
                        const std::atomic<bool>& stop);

}  // namespace coloc::fusion
