// Discovery through sysfs, and the errno explanations every backend shares.
#include <algorithm>
#include <cstring>
#include <fstream>

#include "slam/capture/device.hpp"

namespace coloc::capture {
namespace fs = std::filesystem;
namespace {

std::string read_line(const fs::path& file) {
  std::ifstream in(file);
  std::string line;
  std::getline(in, line);
  return line;
}

std::uint16_t read_hex16(const fs::path& file) {
  const std::string s = read_line(file);
  try {
    return static_cast<std::uint16_t>(std::stoul(s, nullptr, 16));
  } catch (const std::exception&) {
    return 0;
  }
}

// The USB device folder above a video node: the first ancestor with an idVendor file (the
// node's `device` link points at the USB interface).
std::optional<fs::path> usb_device_of(const fs::path& entry) {
  std::error_code ec;
  fs::path p = fs::canonical(entry / "device", ec);
  if (ec) return std::nullopt;
  for (int up = 0; up < 4 && !p.empty() && p != p.root_path(); ++up, p = p.parent_path())
    if (fs::exists(p / "idVendor")) return p;
  return std::nullopt;
}

}  // namespace

std::string explain_errno(int e) {
  switch (e) {
    case ENOENT:
      return "no such device (is the camera plugged in? `coloc devices` lists what is attached)";
    case EBUSY:
      return "device busy: another program holds it (close realsense-viewer, cheese, a browser "
             "tab, or another coloc)";
    case EACCES:
    case EPERM:
      return "permission denied: add yourself to the `video` group (and log in again) or install "
             "the udev rules for Intel RealSense (99-realsense-libusb.rules)";
    case ENODEV:
      return "the camera was unplugged or reset";
    case EINVAL:
      return "the driver refused the request (unsupported mode?)";
    case EIO:
      return "input/output error (USB link trouble: use a USB 3 port and cable)";
    default:
      return std::strerror(e);
  }
}

std::vector<NodeInfo> scan_sysfs(const fs::path& root) {
  std::vector<NodeInfo> nodes;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(root, ec)) {
    const std::string leaf = entry.path().filename().string();
    if (leaf.rfind("video", 0) != 0) continue;
    NodeInfo n;
    n.device = fs::path("/dev") / leaf;
    n.name = read_line(entry.path() / "name");
    try {
      n.index = std::stoi(read_line(entry.path() / "index"));
    } catch (const std::exception&) {
      n.index = 0;
    }
    if (const auto usb = usb_device_of(entry.path())) {
      n.usb_path = usb->string();
      n.vendor = read_hex16(*usb / "idVendor");
      n.product = read_hex16(*usb / "idProduct");
      n.serial = read_line(*usb / "serial");
      n.speed = read_line(*usb / "speed");
    }
    nodes.push_back(std::move(n));
  }
  std::sort(nodes.begin(), nodes.end(), [](const NodeInfo& a, const NodeInfo& b) {
    const std::string sa = a.device.string(), sb = b.device.string();
    return sa.size() != sb.size() ? sa.size() < sb.size() : sa < sb;  // video2 before video10
  });
  return nodes;
}

std::vector<NodeFormat> DeviceSystem::formats_of(const fs::path& device) {
  return open(device)->formats();
}

}  // namespace coloc::capture
