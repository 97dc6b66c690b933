#include "slam/capture/replay.hpp"

#include <chrono>
#include <thread>

#include "slam/capture/bytes.hpp"

namespace coloc::capture {
namespace fs = std::filesystem;
namespace {

class ReplayVideoNode final : public VideoNode {
 public:
  ReplayVideoNode(std::shared_ptr<const ReplayDescription> all, const ReplayNode& node)
      : all_(std::move(all)), node_(node) {}

  const fs::path& path() const override { return node_.info.device; }
  std::vector<NodeFormat> formats() override { return node_.formats; }

  void configure(const StreamMode& mode) override {
    bool offered = false;
    for (const NodeFormat& f : node_.formats) {
      if (f.fourcc != mode.fourcc) continue;
      if (f.sizes.empty()) offered = true;  // metadata
      for (const auto& s : f.sizes)
        if (s.width == mode.width && s.height == mode.height)
          for (double r : s.fps)
            offered = offered || std::abs(r - mode.fps) < 0.5;
    }
    if (!offered || (node_.frames_mode && !node_.frames.empty() && f_mismatch(mode)))
      throw DeviceError("the driver does not offer " + fourcc_name(mode.fourcc) + " " +
                            std::to_string(mode.width) + "x" + std::to_string(mode.height) +
                            " at " + std::to_string(static_cast<int>(mode.fps)) + " fps",
                        EINVAL, path().string());
  }

  void start(unsigned buffers) override {
    if (buffers == 0) throw DeviceError("no buffers requested", EINVAL, path().string());
    started_ = std::chrono::steady_clock::now();
    streaming_ = true;
  }

  std::optional<Buffer> dequeue(int timeout_ms) override {
    if (!streaming_) throw DeviceError("not streaming", EINVAL, path().string());
    if (node_.unplug_after && next_ >= *node_.unplug_after)
      throw DeviceError(explain_errno(ENODEV), ENODEV, path().string());
    if (next_ >= node_.frames.size())
      throw DeviceError("end of the replay", ENODATA, path().string());
    const ReplayFrame& f = node_.frames[next_];
    if (all_->realtime) {
      const auto due =
          started_ + std::chrono::nanoseconds(f.timestamp_ns - node_.frames[0].timestamp_ns);
      const auto limit = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
      if (due > limit) {
        std::this_thread::sleep_until(limit);
        return std::nullopt;
      }
      std::this_thread::sleep_until(due);
    }
    return Buffer{.bytes = f.bytes,
                  .index = static_cast<std::uint32_t>(next_++),
                  .sequence = f.sequence,
                  .timestamp_ns = f.timestamp_ns};
  }

  void requeue(std::uint32_t) override {}
  void stop() override { streaming_ = false; }
  bool paced_by_reader() const override { return !all_->realtime; }

  std::vector<std::uint8_t> xu_query(std::uint8_t unit, std::uint8_t selector, bool set,
                                     std::vector<std::uint8_t> data) override {
    if (node_.xu_errno != 0)
      throw DeviceError("extension unit query failed: " + explain_errno(node_.xu_errno),
                        node_.xu_errno, path().string());
    if (unit != kDepthXuUnit || selector != kHwMonitorSelector)
      throw DeviceError("no such extension unit control", EINVAL, path().string());
    if (set) {
      pending_opcode_ = detail::read_le<std::uint32_t>(data, 4, "hardware monitor opcode");
      pending_param_ = detail::read_le<std::uint32_t>(data, 8, "hardware monitor parameter");
      return data;
    }
    const auto table = node_.tables.find(static_cast<std::uint16_t>(pending_param_));
    if (pending_opcode_ != kOpGetIntCal || table == node_.tables.end()) {
      std::vector<std::uint8_t> answer(kHwMonitorBufferSize, 0);
      detail::write_le<std::int32_t>(answer, 0, -1);  // the firmware's "wrong command"
      return answer;
    }
    return hw_monitor_answer(pending_opcode_, table->second);
  }

 private:
  bool f_mismatch(const StreamMode& mode) const {
    const StreamMode& m = *node_.frames_mode;
    return m.fourcc != mode.fourcc || m.width != mode.width || m.height != mode.height;
  }

  std::shared_ptr<const ReplayDescription> all_;
  const ReplayNode& node_;
  std::size_t next_ = 0;
  bool streaming_ = false;
  std::chrono::steady_clock::time_point started_;
  std::uint32_t pending_opcode_ = 0, pending_param_ = 0;
};

class ReplaySystem final : public DeviceSystem {
 public:
  explicit ReplaySystem(ReplayDescription d)
      : all_(std::make_shared<const ReplayDescription>(std::move(d))) {}

  std::vector<NodeInfo> list() override {
    std::vector<NodeInfo> out;
    for (const ReplayNode& n : all_->nodes)
      out.push_back(n.info);
    return out;
  }

  std::unique_ptr<VideoNode> open(const fs::path& device) override {
    for (const ReplayNode& n : all_->nodes) {
      if (n.info.device != device) continue;
      if (n.open_errno != 0)
        throw DeviceError("cannot open: " + explain_errno(n.open_errno), n.open_errno,
                          device.string());
      return std::make_unique<ReplayVideoNode>(all_, n);
    }
    throw DeviceError("cannot open: " + explain_errno(ENOENT), ENOENT, device.string());
  }

 private:
  std::shared_ptr<const ReplayDescription> all_;
};

NodeInfo d455_info(int number, int index, const std::string& name) {
  return {.device = "/dev/video" + std::to_string(number),
          .name = name,
          .index = index,
          .usb_path = "/sys/devices/pci0000:00/0000:00:14.0/usb2/2-1",
          .vendor = 0x8086,
          .product = 0x0b5c,
          .serial = "replay-d455",
          .speed = "5000"};
}

}  // namespace

std::unique_ptr<DeviceSystem> replay_system(ReplayDescription description) {
  return std::make_unique<ReplaySystem>(std::move(description));
}

ReplayDescription d455_description(const DepthColorCalibration& calibration) {
  const std::string name = "Intel(R) RealSense(TM) Depth Camera 455";
  ReplayDescription d;
  ReplayNode depth{.info = d455_info(0, 0, name + "  Depth")};
  depth.formats = {
      {kFourccZ16, {{848, 480, {5, 15, 30, 60, 90}}, {640, 480, {5, 15, 30, 60, 90}}}}};
  depth.tables[kTableCoefficients] = build_coefficients_table(calibration);
  depth.tables[kTableRgb] = build_rgb_table(calibration);
  ReplayNode depth_meta{.info = d455_info(1, 1, name + "  Depth")};
  depth_meta.formats = {{kFourccUvcMeta, {}}};
  ReplayNode infrared{.info = d455_info(2, 0, name + "  Depth")};
  infrared.formats = {{kFourccGrey, {{848, 480, {30, 60, 90}}}}, {kFourccY8i, {{848, 480, {30}}}}};
  ReplayNode color{.info = d455_info(4, 0, name + "  RGB")};
  color.formats = {{kFourccYuyv, {{640, 480, {5, 15, 30}}, {1280, 720, {5, 15, 30}}}}};
  ReplayNode color_meta{.info = d455_info(5, 1, name + "  RGB")};
  color_meta.formats = {{kFourccUvcMeta, {}}};
  d.nodes = {depth, depth_meta, infrared, color, color_meta};
  return d;
}

}  // namespace coloc::capture
