#pragma once
// A camera that is not there: ReplaySystem implements DeviceSystem from a recorded description
// (nodes with their sysfs facts and formats, frames with their sequence numbers and kernel
// timestamps, calibration tables behind the hardware monitor) and the failures users meet:
// open() refused with EBUSY / EACCES, an unsupported mode (EINVAL), the camera unplugged after
// N frames (ENODEV), a failing extension-unit query. The capture code cannot tell it from
// KernelSystem; the tests and `coloc record --camera replay:DIR` drive it.
//
// On disk (save_replay / load_replay): DIR/replay.yaml (OpenCV FileStorage) and one raw file per
// frame under DIR/frames/. The end of a node's frames is reported as DeviceError(ENODATA).
#include <filesystem>
#include <map>
#include <optional>

#include "slam/capture/calibration.hpp"
#include "slam/capture/device.hpp"
#include "slam/capture/formats.hpp"

namespace coloc::capture {

struct ReplayFrame {
  std::vector<std::uint8_t> bytes;
  std::uint32_t sequence = 0;
  std::int64_t timestamp_ns = 0;
};

struct ReplayNode {
  NodeInfo info;
  std::vector<NodeFormat> formats;
  std::optional<StreamMode> frames_mode;  // the mode the frames were recorded in
  std::vector<ReplayFrame> frames;
  int open_errno = 0;                       // open() fails with it (EBUSY, EACCES, ...)
  std::optional<std::size_t> unplug_after;  // frames served before ENODEV
  int xu_errno = 0;                         // extension-unit queries fail with it
  std::map<std::uint16_t, std::vector<std::uint8_t>> tables;  // GETINTCAL answers by table id
};

struct ReplayDescription {
  std::vector<ReplayNode> nodes;
  // Frames are served at the pace of their timestamps (a live camera) instead of on demand.
  bool realtime = false;
};

std::unique_ptr<DeviceSystem> replay_system(ReplayDescription description);

void save_replay(const ReplayDescription& description, const std::filesystem::path& dir);
// Throws coloc::Error naming the file and key.
ReplayDescription load_replay(const std::filesystem::path& dir);

// A D455 (depth Z16 with metadata node, colour YUYV with metadata node, IMU-less) as sysfs and
// the formats show it, without frames: the base of the tests' and the CLI's replays.
ReplayDescription d455_description(const DepthColorCalibration& calibration);

}  // namespace coloc::capture
