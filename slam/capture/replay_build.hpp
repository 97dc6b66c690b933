#pragma once
// Replay descriptions made from recorded RGB-D frames: the bytes a D455 would send for them
// (Z16 depth, YUYV colour, UVC metadata with sensor timestamps) with a calibration whose depth
// camera is the frames' camera (so registration gives the frames back). Used by the tests,
// `coloc devices make-replay` and `coloc bench capture`.
#include "slam/capture/replay.hpp"
#include "slam/dataset/sequence.hpp"

namespace coloc::capture {

struct ReplayBuildOptions {
  std::size_t frames = 0;  // 0: all
  double fps = 30.0;
  std::optional<std::size_t> unplug_after;  // the camera disappears after this many frames
  std::vector<std::uint32_t> kernel_drops;  // frame indices the "driver" drops (sequence gaps)
  bool metadata = true;
  bool realtime = false;
};

// The calibration a replay of `camera` carries (depth = colour camera, identity extrinsic).
DepthColorCalibration calibration_for(const PinholeCamera& camera);

// Throws coloc::Error when the sequence has no depth or an odd image width.
ReplayDescription replay_from_sequence(const dataset::Sequence& sequence,
                                       const PinholeCamera& camera,
                                       const ReplayBuildOptions& options);

}  // namespace coloc::capture
