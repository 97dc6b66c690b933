#include "slam/capture/discovery.hpp"

#include <map>

#include "slam/capture/formats.hpp"

namespace coloc::capture {
namespace {

constexpr std::uint16_t kIntel = 0x8086;

StreamKind classify(const std::vector<NodeFormat>& formats) {
  bool depth = false, color = false, infrared = false, meta = false;
  for (const NodeFormat& f : formats) {
    depth = depth || f.fourcc == kFourccZ16;
    color =
        color || f.fourcc == kFourccYuyv || f.fourcc == kFourccRgb24 || f.fourcc == kFourccBgr24;
    infrared =
        infrared || f.fourcc == kFourccGrey || f.fourcc == kFourccY8i || f.fourcc == kFourccY12i;
    meta = meta || f.fourcc == kFourccUvcMeta;
  }
  if (depth) return StreamKind::kDepth;  // a depth node may offer infrared formats too
  if (color) return StreamKind::kColor;
  if (infrared) return StreamKind::kInfrared;
  if (meta) return StreamKind::kMetadata;
  return StreamKind::kOther;
}

}  // namespace

std::string kind_name(StreamKind kind) {
  switch (kind) {
    case StreamKind::kDepth:
      return "depth";
    case StreamKind::kColor:
      return "color";
    case StreamKind::kInfrared:
      return "infrared";
    case StreamKind::kMetadata:
      return "metadata";
    default:
      return "other";
  }
}

std::string d4xx_model(std::uint16_t product) {
  static const std::map<std::uint16_t, std::string> kModels = {
      {0x0b5c, "D455"}, {0x0b07, "D435"}, {0x0b3a, "D435i"}, {0x0ad3, "D415"},
      {0x0ad2, "D410"}, {0x0b5b, "D405"}, {0x0b64, "D455f"}, {0x0b4b, "D430i"}};
  const auto it = kModels.find(product);
  return it == kModels.end() ? std::string() : it->second;
}

const DiscoveredNode* RealSenseDevice::first(StreamKind kind) const {
  for (const DiscoveredNode& n : nodes)
    if (n.kind == kind) return &n;
  return nullptr;
}

const DiscoveredNode* RealSenseDevice::metadata_of(const DiscoveredNode& stream) const {
  for (std::size_t i = 0; i + 1 < nodes.size(); ++i)
    if (&nodes[i] == &stream && nodes[i + 1].kind == StreamKind::kMetadata) return &nodes[i + 1];
  return nullptr;
}

Discovery discover(DeviceSystem& system) {
  Discovery d;
  std::map<std::string, std::size_t> by_usb;
  for (const NodeInfo& info : system.list()) {
    ++d.video_nodes;
    if (info.vendor != kIntel) continue;
    DiscoveredNode node{.info = info};
    try {
      node.formats = system.formats_of(info.device);
      node.kind = classify(node.formats);
    } catch (const DeviceError& e) {
      node.error = e.what();
      node.error_number = e.error_number();
      d.problems.push_back(e.what());
    }
    auto [it, added] = by_usb.try_emplace(info.usb_path, d.devices.size());
    if (added) {
      const std::string model = d4xx_model(info.product);
      char hex[16];
      std::snprintf(hex, sizeof(hex), "0x%04x", info.product);
      d.devices.push_back(
          {.model = model.empty() ? "unknown Intel camera (" + std::string(hex) + ")" : model,
           .product = info.product,
           .serial = info.serial,
           .usb_path = info.usb_path,
           .speed = info.speed});
    }
    d.devices[it->second].nodes.push_back(std::move(node));
  }
  return d;
}

std::string no_camera_advice(const Discovery& d) {
  std::string s = "no RealSense camera found (" + std::to_string(d.video_nodes) +
                  " V4L2 nodes seen). Check:\n"
                  "  - the camera is on a USB 3 port with a USB 3 cable (lsusb -t shows 5000M)\n"
                  "  - the uvcvideo module is loaded (lsmod | grep uvcvideo)\n"
                  "  - /dev/video* are readable by you: the `video` group, or Intel's udev rules\n"
                  "    (99-realsense-libusb.rules) and a replug\n"
                  "  - no other program (realsense-viewer, a browser) holds the camera";
  for (const std::string& p : d.problems)
    s += "\n  ! " + p;
  return s;
}

}  // namespace coloc::capture
