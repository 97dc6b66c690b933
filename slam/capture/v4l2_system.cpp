// The real kernel behind VideoNode: V4L2 ioctls (<linux/videodev2.h>) and the UVC extension
// unit query (<linux/uvcvideo.h>). Only this file talks to the kernel's video ABI.
#include <fcntl.h>
#include <linux/usb/video.h>
#include <linux/uvcvideo.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cmath>
#include <cstring>

#include "slam/capture/device.hpp"
#include "slam/capture/formats.hpp"

namespace coloc::capture {
namespace fs = std::filesystem;
namespace {

int xioctl(int fd, unsigned long request, void* arg) {
  int r = 0;
  do {
    r = ::ioctl(fd, request, arg);
  } while (r == -1 && errno == EINTR);
  return r;
}

class KernelNode final : public VideoNode {
 public:
  explicit KernelNode(fs::path path) : path_(std::move(path)) {
    fd_ = ::open(path_.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
    if (fd_ < 0) fail("cannot open");
    v4l2_capability cap{};
    if (xioctl(fd_, VIDIOC_QUERYCAP, &cap) < 0) fail("not a V4L2 device");
    const std::uint32_t caps =
        (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
    metadata_ = (caps & V4L2_CAP_META_CAPTURE) != 0;
    type_ = metadata_ ? V4L2_BUF_TYPE_META_CAPTURE : V4L2_BUF_TYPE_VIDEO_CAPTURE;
  }
  ~KernelNode() override {
    stop();
    if (fd_ >= 0) ::close(fd_);
  }
  KernelNode(const KernelNode&) = delete;
  KernelNode& operator=(const KernelNode&) = delete;

  const fs::path& path() const override { return path_; }

  std::vector<NodeFormat> formats() override {
    std::vector<NodeFormat> out;
    for (std::uint32_t i = 0;; ++i) {
      v4l2_fmtdesc d{};
      d.index = i;
      d.type = type_;
      if (xioctl(fd_, VIDIOC_ENUM_FMT, &d) < 0) break;
      NodeFormat f{.fourcc = d.pixelformat};
      if (!metadata_) f.sizes = sizes(d.pixelformat);
      out.push_back(std::move(f));
    }
    return out;
  }

  void configure(const StreamMode& mode) override {
    v4l2_format f{};
    f.type = type_;
    if (metadata_) {
      f.fmt.meta.dataformat = mode.fourcc;
      if (xioctl(fd_, VIDIOC_S_FMT, &f) < 0) fail("cannot set the metadata format");
      return;
    }
    f.fmt.pix.width = static_cast<std::uint32_t>(mode.width);
    f.fmt.pix.height = static_cast<std::uint32_t>(mode.height);
    f.fmt.pix.pixelformat = mode.fourcc;
    f.fmt.pix.field = V4L2_FIELD_NONE;
    if (xioctl(fd_, VIDIOC_S_FMT, &f) < 0) fail("cannot set format " + describe(mode));
    if (f.fmt.pix.width != static_cast<std::uint32_t>(mode.width) ||
        f.fmt.pix.height != static_cast<std::uint32_t>(mode.height) ||
        f.fmt.pix.pixelformat != mode.fourcc)
      throw DeviceError("the driver does not offer " + describe(mode), EINVAL, path_.string());
    v4l2_streamparm p{};
    p.type = type_;
    p.parm.capture.timeperframe.numerator = 1000;
    p.parm.capture.timeperframe.denominator =
        static_cast<std::uint32_t>(std::lround(mode.fps * 1000));
    if (xioctl(fd_, VIDIOC_S_PARM, &p) < 0) fail("cannot set " + describe(mode));
    const auto& tpf = p.parm.capture.timeperframe;
    if (tpf.numerator == 0 ||
        std::abs(static_cast<double>(tpf.denominator) / tpf.numerator - mode.fps) > 0.5)
      throw DeviceError("the driver does not offer " + describe(mode), EINVAL, path_.string());
  }

  void start(unsigned count) override {
    v4l2_requestbuffers req{};
    req.count = count;
    req.type = type_;
    req.memory = V4L2_MEMORY_MMAP;
    if (xioctl(fd_, VIDIOC_REQBUFS, &req) < 0) fail("cannot allocate buffers");
    for (std::uint32_t i = 0; i < req.count; ++i) {
      v4l2_buffer b{};
      b.type = type_;
      b.memory = V4L2_MEMORY_MMAP;
      b.index = i;
      if (xioctl(fd_, VIDIOC_QUERYBUF, &b) < 0) fail("cannot query a buffer");
      void* p = ::mmap(nullptr, b.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, b.m.offset);
      if (p == MAP_FAILED) fail("cannot map a buffer");
      maps_.push_back({static_cast<std::uint8_t*>(p), b.length});
      requeue(i);
    }
    int type = static_cast<int>(type_);
    if (xioctl(fd_, VIDIOC_STREAMON, &type) < 0) fail("cannot start streaming");
    streaming_ = true;
  }

  std::optional<Buffer> dequeue(int timeout_ms) override {
    pollfd p{fd_, POLLIN, 0};
    const int r = ::poll(&p, 1, timeout_ms);
    if (r < 0 && errno != EINTR) fail("poll failed");
    if (r <= 0) return std::nullopt;
    if (p.revents & (POLLERR | POLLHUP))
      throw DeviceError(explain_errno(ENODEV), ENODEV, path_.string());
    v4l2_buffer b{};
    b.type = type_;
    b.memory = V4L2_MEMORY_MMAP;
    if (xioctl(fd_, VIDIOC_DQBUF, &b) < 0) {
      if (errno == EAGAIN) return std::nullopt;
      fail("cannot dequeue a buffer");
    }
    const auto& m = maps_.at(b.index);
    return Buffer{.bytes = {m.data, std::min<std::size_t>(b.bytesused, m.length)},
                  .index = b.index,
                  .sequence = b.sequence,
                  .timestamp_ns = static_cast<std::int64_t>(b.timestamp.tv_sec) * 1000000000 +
                                  static_cast<std::int64_t>(b.timestamp.tv_usec) * 1000};
  }

  void requeue(std::uint32_t index) override {
    v4l2_buffer b{};
    b.type = type_;
    b.memory = V4L2_MEMORY_MMAP;
    b.index = index;
    if (xioctl(fd_, VIDIOC_QBUF, &b) < 0) fail("cannot queue a buffer");
  }

  void stop() override {
    if (streaming_) {
      int type = static_cast<int>(type_);
      xioctl(fd_, VIDIOC_STREAMOFF, &type);  // best effort: the device may be gone
      streaming_ = false;
    }
    for (const auto& m : maps_)
      ::munmap(m.data, m.length);
    maps_.clear();
  }

  std::vector<std::uint8_t> xu_query(std::uint8_t unit, std::uint8_t selector, bool set,
                                     std::vector<std::uint8_t> data) override {
    uvc_xu_control_query q{};
    q.unit = unit;
    q.selector = selector;
    q.query = set ? UVC_SET_CUR : UVC_GET_CUR;
    q.size = static_cast<std::uint16_t>(data.size());
    q.data = data.data();
    if (xioctl(fd_, UVCIOC_CTRL_QUERY, &q) < 0)
      fail("extension unit " + std::to_string(unit) + " control " + std::to_string(selector) +
           " query failed");
    return data;
  }

 private:
  struct Map {
    std::uint8_t* data;
    std::size_t length;
  };

  [[noreturn]] void fail(const std::string& what) const {
    const int e = errno;
    throw DeviceError(what + ": " + explain_errno(e), e, path_.string());
  }

  static std::string describe(const StreamMode& m) {
    return fourcc_name(m.fourcc) + " " + std::to_string(m.width) + "x" + std::to_string(m.height) +
           " at " + std::to_string(static_cast<int>(m.fps)) + " fps";
  }

  std::vector<NodeFormat::Size> sizes(std::uint32_t code) const {
    std::vector<NodeFormat::Size> out;
    for (std::uint32_t i = 0;; ++i) {
      v4l2_frmsizeenum s{};
      s.index = i;
      s.pixel_format = code;
      if (xioctl(fd_, VIDIOC_ENUM_FRAMESIZES, &s) < 0 || s.type != V4L2_FRMSIZE_TYPE_DISCRETE)
        break;
      NodeFormat::Size size{
          static_cast<int>(s.discrete.width), static_cast<int>(s.discrete.height), {}};
      for (std::uint32_t k = 0;; ++k) {
        v4l2_frmivalenum iv{};
        iv.index = k;
        iv.pixel_format = code;
        iv.width = s.discrete.width;
        iv.height = s.discrete.height;
        if (xioctl(fd_, VIDIOC_ENUM_FRAMEINTERVALS, &iv) < 0 ||
            iv.type != V4L2_FRMIVAL_TYPE_DISCRETE)
          break;
        if (iv.discrete.numerator > 0)
          size.fps.push_back(static_cast<double>(iv.discrete.denominator) / iv.discrete.numerator);
      }
      out.push_back(std::move(size));
    }
    return out;
  }

  fs::path path_;
  int fd_ = -1;
  bool metadata_ = false;
  std::uint32_t type_ = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  bool streaming_ = false;
  std::vector<Map> maps_;
};

class KernelSystem final : public DeviceSystem {
 public:
  explicit KernelSystem(fs::path root) : root_(std::move(root)) {}
  std::vector<NodeInfo> list() override { return scan_sysfs(root_); }
  std::unique_ptr<VideoNode> open(const fs::path& device) override {
    return std::make_unique<KernelNode>(device);
  }

 private:
  fs::path root_;
};

}  // namespace

std::unique_ptr<DeviceSystem> kernel_system(fs::path sysfs_root) {
  return std::make_unique<KernelSystem>(std::move(sysfs_root));
}

}  // namespace coloc::capture
