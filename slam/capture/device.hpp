#pragma once
// The narrow interface between the capture code and the kernel: everything coloc does with a
// V4L2 node goes through VideoNode, and finding nodes through DeviceSystem. KernelSystem (the
// real ioctls, v4l2_system.cpp) and ReplaySystem (a recorded description, replay.hpp) implement
// it, so the capture code above this line is the same with a camera and in the tests.
#include <cerrno>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "slam/core/error.hpp"

namespace coloc::capture {

struct StreamMode {
  std::uint32_t fourcc = 0;
  int width = 0, height = 0;
  double fps = 0.0;
  bool operator==(const StreamMode&) const = default;
};

// One format of a node with every size and rate it offers (V4L2 ENUM_FMT / FRAMESIZES /
// FRAMEINTERVALS). Metadata nodes have one format with size 0x0 and no rates.
struct NodeFormat {
  std::uint32_t fourcc = 0;
  struct Size {
    int width = 0, height = 0;
    std::vector<double> fps;
  };
  std::vector<Size> sizes;
};

// What sysfs says of a node (without opening it).
struct NodeInfo {
  std::filesystem::path device;  // /dev/videoN
  std::string name;              // sysfs name (the UVC function's name)
  int index = 0;                 // sysfs index: 0 for the stream node, 1 for its metadata node
  std::string usb_path;          // the USB device's sysfs folder (groups the nodes of a camera)
  std::uint16_t vendor = 0, product = 0;
  std::string serial, speed;  // "5000" for USB 3
};

// One dequeued buffer. `bytes` stays valid until the buffer is handed back by requeue().
struct Buffer {
  std::span<const std::uint8_t> bytes;
  std::uint32_t index = 0;        // to requeue
  std::uint32_t sequence = 0;     // the driver's frame counter: gaps are frames it dropped
  std::int64_t timestamp_ns = 0;  // kernel timestamp (CLOCK_MONOTONIC)
};

// Thrown by VideoNode calls with the errno that caused it, so callers can tell an unplugged
// camera (ENODEV) from the rest. The message names the node and what to do.
class DeviceError : public Error {
 public:
  DeviceError(const std::string& message, int error_number, const std::string& node)
      : Error(message, {.file = node}), errno_(error_number) {}
  int error_number() const { return errno_; }
  bool unplugged() const { return errno_ == ENODEV; }

 private:
  int errno_;
};

// The user-facing explanation of an errno from opening or streaming a node.
std::string explain_errno(int error_number);

class VideoNode {
 public:
  virtual ~VideoNode() = default;
  virtual const std::filesystem::path& path() const = 0;
  virtual std::vector<NodeFormat> formats() = 0;
  // S_FMT + S_PARM; throws DeviceError (EINVAL) naming the mode when the driver refuses it
  // or answers with another size, format or rate.
  virtual void configure(const StreamMode& mode) = 0;
  // REQBUFS + mmap + QBUF + STREAMON.
  virtual void start(unsigned buffers) = 0;
  // Waits up to timeout_ms for a filled buffer (nothing on timeout); throws DeviceError (ENODEV
  // when unplugged).
  virtual std::optional<Buffer> dequeue(int timeout_ms) = 0;
  virtual void requeue(std::uint32_t index) = 0;
  virtual void stop() = 0;  // STREAMOFF, unmap; never throws
  // True for a node without a clock of its own (a replay served on demand): it gives a frame
  // when asked, so its stream waits for the consumer instead of dropping. Nothing is lost then,
  // however slow the machine; a camera (false) runs at its own pace and drops what the consumer
  // cannot take.
  virtual bool paced_by_reader() const { return false; }
  // UVCIOC_CTRL_QUERY: SET_CUR `data` when `set`, else GET_CUR of data.size() bytes.
  virtual std::vector<std::uint8_t> xu_query(std::uint8_t unit, std::uint8_t selector, bool set,
                                             std::vector<std::uint8_t> data) = 0;
};

class DeviceSystem {
 public:
  virtual ~DeviceSystem() = default;
  virtual std::vector<NodeInfo> list() = 0;
  // Throws DeviceError with the errno (ENOENT, EBUSY, EACCES ...) and its explanation.
  virtual std::unique_ptr<VideoNode> open(const std::filesystem::path& device) = 0;
  // Formats of a node, opened only for the query (discovery).
  std::vector<NodeFormat> formats_of(const std::filesystem::path& device);
};

// The real kernel: sysfs under `sysfs_root` (/sys/class/video4linux), nodes under /dev.
std::unique_ptr<DeviceSystem> kernel_system(
    std::filesystem::path sysfs_root = "/sys/class/video4linux");

// Reads the nodes of a sysfs tree laid out as /sys/class/video4linux: each entry's `name`,
// `index` and the USB device above its `device` link (idVendor, idProduct, serial, speed).
std::vector<NodeInfo> scan_sysfs(const std::filesystem::path& sysfs_root);

}  // namespace coloc::capture
