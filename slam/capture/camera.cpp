#include "slam/capture/camera.hpp"

#include <spdlog/spdlog.h>

#include <regex>

namespace coloc::capture {
namespace {

constexpr int kMetadataWaitMs = 20;

std::unique_ptr<NodeStream> open_stream(DeviceSystem& system, const DiscoveredNode& node,
                                        const StreamMode& mode, const CameraOptions& o) {
  std::unique_ptr<VideoNode> v = system.open(node.info.device);
  v->configure(mode);
  return std::make_unique<NodeStream>(std::move(v), o.buffers, o.queue_capacity);
}

// Metadata is a bonus (sensor timestamps): without it the kernel timestamps are used.
std::unique_ptr<NodeStream> open_metadata(DeviceSystem& system, const RealSenseDevice& device,
                                          const DiscoveredNode& stream, const CameraOptions& o) {
  const DiscoveredNode* meta = device.metadata_of(stream);
  if (meta == nullptr) {
    spdlog::warn("{}: no metadata node; kernel timestamps are used", stream.info.device.string());
    return nullptr;
  }
  try {
    return open_stream(system, *meta, {kFourccUvcMeta, 0, 0, 0.0}, o);
  } catch (const Error& e) {
    spdlog::warn("metadata node {}: {}; kernel timestamps are used", meta->info.device.string(),
                 e.what());
    return nullptr;
  }
}

}  // namespace

struct RgbdCamera::StreamState {
  std::unique_ptr<NodeStream> video, meta;
  std::optional<RawFrame> pending_meta;  // metadata of a later frame, kept for it
  std::optional<double> kernel_minus_sensor;
};

void CameraOptions::check() const {
  auto positive = [](bool ok, const char* field) {
    if (!ok) throw Error("must be positive", {.field = field});
  };
  positive(depth.width > 0 && depth.height > 0 && depth.fps > 0, "depth mode");
  positive(color.width > 0 && color.height > 0 && color.fps > 0, "color mode");
  positive(depth_units_per_metre > 0, "depth_units_per_metre");
  positive(max_pair_dt > 0, "max_pair_dt");
  positive(buffers >= 2, "buffers (at least 2)");
  positive(queue_capacity > 0, "queue_capacity");
  if (depth.fourcc != kFourccZ16) throw Error("depth must be Z16", {.field = "depth mode"});
}

void parse_mode(const std::string& text, CameraOptions& o) {
  static const std::regex kItem(R"((depth|color)=(\d+)x(\d+)@(\d+))");
  std::size_t consumed = 0;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), kItem);
       it != std::sregex_iterator(); ++it) {
    const std::smatch& m = *it;
    StreamMode& mode = m[1] == "depth" ? o.depth : o.color;
    mode.width = std::stoi(m[2]);
    mode.height = std::stoi(m[3]);
    mode.fps = std::stod(m[4]);
    consumed += static_cast<std::size_t>(m.length()) + 1;
  }
  if (consumed == 0 || consumed < text.size())
    throw Error("'" + text + "': expected depth=WxH@FPS,color=WxH@FPS (e.g. depth=848x480@30)",
                {.field = "--mode"});
}

RealSenseDevice find_camera(DeviceSystem& system, const std::string& device) {
  const Discovery d = discover(system);
  for (const RealSenseDevice& dev : d.devices) {
    const bool usable = dev.first(StreamKind::kDepth) && dev.first(StreamKind::kColor);
    if (device == "auto" && usable) return dev;
    for (const DiscoveredNode& n : dev.nodes)
      if (n.info.device == device) {
        if (!usable)
          throw Error(device + " belongs to a " + dev.model +
                      " without both depth and colour nodes");
        return dev;
      }
  }
  // A camera whose nodes could not be opened: the reason (busy, permissions) is the answer.
  for (const RealSenseDevice& dev : d.devices)
    for (const DiscoveredNode& n : dev.nodes)
      if (n.error_number != 0) throw DeviceError(n.error, n.error_number, n.info.device.string());
  if (device != "auto")
    throw Error(device + " is not a node of a RealSense camera.\n" + no_camera_advice(d));
  throw Error(no_camera_advice(d));
}

DepthColorCalibration read_factory_calibration(VideoNode& node) {
  auto table = [&](std::uint16_t id) {
    node.xu_query(kDepthXuUnit, kHwMonitorSelector, true, hw_monitor_command(kOpGetIntCal, id));
    const auto answer = node.xu_query(kDepthXuUnit, kHwMonitorSelector, false,
                                      std::vector<std::uint8_t>(kHwMonitorBufferSize, 0));
    return hw_monitor_payload(answer, kOpGetIntCal);
  };
  try {
    const auto coefficients = table(kTableCoefficients);
    return parse_calibration(coefficients, table(kTableRgb));
  } catch (const Error& e) {
    throw Error("cannot read the factory calibration from " + node.path().string() + ": " +
                e.what() +
                "\n  fallback: pass --calibration FILE (a camera YAML, e.g. from "
                "`coloc calibrate`)");
  }
}

RgbdCamera::RgbdCamera(DeviceSystem& system, const CameraOptions& options)
    : options_(options), pairer_(options.max_pair_dt) {
  options_.check();
  device_ = find_camera(system, options_.device);
  const DiscoveredNode& depth_node = *device_.first(StreamKind::kDepth);
  const DiscoveredNode& color_node = *device_.first(StreamKind::kColor);
  if (!device_.usb3())
    spdlog::warn("{} is on USB {} Mbit/s: expect dropped frames (use a USB 3 port and cable)",
                 device_.model, device_.speed);
  if (options_.calibration_file.empty()) {
    std::unique_ptr<VideoNode> probe = system.open(depth_node.info.device);
    calibration_ = read_factory_calibration(*probe);
  } else {
    calibration_ = load_calibration_file(options_.calibration_file, options_.depth.width,
                                         options_.depth.height);
  }
  depth_camera_ = calibration_.depth_camera(options_.depth.width, options_.depth.height);
  color_camera_ = calibration_.color_camera(options_.color.width, options_.color.height);
  registrar_ =
      std::make_unique<DepthRegistrar>(depth_camera_, color_camera_, calibration_.color_from_depth);
  depth_ = std::make_unique<StreamState>();
  color_ = std::make_unique<StreamState>();
  depth_->meta = open_metadata(system, device_, depth_node, options_);
  color_->meta = open_metadata(system, device_, color_node, options_);
  depth_->video = open_stream(system, depth_node, options_.depth, options_);
  color_->video = open_stream(system, color_node, options_.color, options_);
}

RgbdCamera::~RgbdCamera() {
  stop();
}

void RgbdCamera::stop() {
  for (StreamState* s : {depth_.get(), color_.get()}) {
    if (s == nullptr) continue;
    if (s->video) s->video->stop();
    if (s->meta) s->meta->stop();
  }
}

double RgbdCamera::frame_time(StreamState& s, const RawFrame& f) {
  const double kernel_s = static_cast<double>(f.kernel_ns) * 1e-9;
  if (!anchor_s_) anchor_s_ = kernel_s;
  if (!s.meta) return kernel_s;
  std::optional<FrameMetadata> meta;
  while (!meta) {
    std::optional<RawFrame> m = std::move(s.pending_meta);
    s.pending_meta.reset();
    // A camera's metadata is due at once, or lost: waiting longer would hold up the frames. A
    // replay paced by its reader has every frame's metadata coming, however slow the machine.
    if (!m) m = s.meta->paced_by_reader() ? s.meta->pop() : s.meta->pop_for(kMetadataWaitMs);
    if (!m || m->sequence > f.sequence) {
      s.pending_meta = std::move(m);
      break;
    }
    if (m->sequence < f.sequence) continue;  // metadata of a frame that was dropped
    try {
      meta = parse_uvc_metadata(m->bytes);
    } catch (const Error& e) {
      spdlog::debug("bad metadata for frame {}: {}", f.sequence, e.what());
      break;
    }
  }
  if (meta && meta->sensor_timestamp_us) {
    const double t = *anchor_s_ + sensor_clock_.seconds(*meta->sensor_timestamp_us);
    s.kernel_minus_sensor = kernel_s - t;
    return t;
  }
  ++metadata_missing_;
  return s.kernel_minus_sensor ? kernel_s - *s.kernel_minus_sensor : kernel_s;
}

RgbdFrame RgbdCamera::decode(const RawFrame& depth, const RawFrame& color, double td, double tc) {
  RgbdFrame out;
  out.timestamp = tc;
  out.depth_timestamp = td;
  out.sensor_clock = depth_->meta && color_->meta;
  out.color =
      decode_color(color.bytes, options_.color.fourcc, options_.color.width, options_.color.height);
  const cv::Mat raw = decode_z16(depth.bytes, options_.depth.width, options_.depth.height);
  out.depth_raw = registrar_->register_raw(raw, options_.depth_units_per_metre);
  return out;
}

std::optional<RgbdFrame> RgbdCamera::next() {
  bool ended = false;
  for (;;) {
    if (auto p = pairer_.next(ended)) {
      try {
        return decode(p->depth, p->color, p->t_depth, p->t_color);
      } catch (const Error& e) {
        spdlog::warn("frame at {:.6f} s skipped: {}", p->t_color, e.what());
        continue;
      }
    }
    if (ended) return std::nullopt;
    const bool want_depth = pairer_.wants_depth();
    StreamState& s = want_depth ? *depth_ : *color_;
    std::optional<RawFrame> f = s.video->pop();
    if (!f) {  // that stream ended: pair what is left, then stop
      ended = true;
      continue;
    }
    const double t = frame_time(s, *f);
    if (want_depth)
      pairer_.add_depth(t, std::move(*f));
    else
      pairer_.add_color(t, std::move(*f));
  }
}

double RgbdCamera::frame_time_of_host(double host_s) const {
  return depth_->kernel_minus_sensor ? host_s - *depth_->kernel_minus_sensor : host_s;
}

CaptureStats RgbdCamera::stats() const {
  return {depth_->video->counters(), color_->video->counters(), pairer_.counters(),
          metadata_missing_};
}

std::optional<std::string> RgbdCamera::end_reason() const {
  for (const StreamState* s : {depth_.get(), color_.get()})
    if (auto e = s->video->error()) return e->first;
  return std::nullopt;
}

bool RgbdCamera::unplugged() const {
  for (const StreamState* s : {depth_.get(), color_.get()})
    if (auto e = s->video->error(); e && e->second == ENODEV) return true;
  return false;
}

}  // namespace coloc::capture
