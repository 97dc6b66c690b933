#pragma once
// Finding RealSense D4xx cameras: the V4L2 nodes of one USB device (Intel, 0x8086) grouped
// together, and each node's role told by its formats (Z16 depth, YUYV/RGB colour, GREY/Y8I/Y12I
// infrared, UVCH metadata; a metadata node belongs to the stream node just before it).
#include <optional>
#include <string>
#include <vector>

#include "slam/capture/device.hpp"

namespace coloc::capture {

enum class StreamKind { kDepth, kColor, kInfrared, kMetadata, kOther };
std::string kind_name(StreamKind kind);

struct DiscoveredNode {
  NodeInfo info;
  StreamKind kind = StreamKind::kOther;
  std::vector<NodeFormat> formats;
  std::string error;  // why the node could not be queried (then kind is kOther)
  int error_number = 0;
};

struct RealSenseDevice {
  std::string model;  // "D455", or "unknown D4xx (0x....)"
  std::uint16_t product = 0;
  std::string serial, usb_path, speed;
  std::vector<DiscoveredNode> nodes;

  bool usb3() const { return !speed.empty() && speed != "480" && speed != "12"; }
  const DiscoveredNode* first(StreamKind kind) const;
  // The metadata node following `stream` (same USB device), if any.
  const DiscoveredNode* metadata_of(const DiscoveredNode& stream) const;
};

struct Discovery {
  std::vector<RealSenseDevice> devices;
  std::size_t video_nodes = 0;  // every V4L2 node seen, RealSense or not
  // Nodes of RealSense devices that could not be opened, with the reason.
  std::vector<std::string> problems;
};

// "D455" for 0x0b5c, "D435" 0x0b07, "D435i" 0x0b3a, "D415" 0x0ad3, ... (empty if not D4xx).
std::string d4xx_model(std::uint16_t product);

Discovery discover(DeviceSystem& system);

// What to check when nothing was found (permissions, udev rules, USB 3, the uvcvideo module).
std::string no_camera_advice(const Discovery& discovery);

}  // namespace coloc::capture
