#include "slam/capture/replay_build.hpp"

#include <algorithm>
#include <cmath>

namespace coloc::capture {
namespace {

std::vector<std::uint8_t> z16_bytes(const cv::Mat& depth_m) {
  std::vector<std::uint8_t> out(depth_m.total() * 2);
  std::size_t k = 0;
  for (int y = 0; y < depth_m.rows; ++y) {
    const float* row = depth_m.ptr<float>(y);
    for (int x = 0; x < depth_m.cols; ++x) {
      const float mm = std::clamp(row[x] * 1000.0f + 0.5f, 0.0f, 65535.0f);
      const auto v = static_cast<std::uint16_t>(mm);
      out[k++] = static_cast<std::uint8_t>(v & 0xff);
      out[k++] = static_cast<std::uint8_t>(v >> 8);
    }
  }
  return out;
}

}  // namespace

DepthColorCalibration calibration_for(const PinholeCamera& camera) {
  DepthColorCalibration c;
  c.baseline_m = 0.095;
  PinholeCamera depth = camera;
  depth.distortion = {};
  c.depth_modes = {depth};
  c.color_calib_width = camera.width;
  c.color_calib_height = camera.height;
  c.color_normalized = {camera.fx / (camera.width / 2.0), camera.fy / (camera.height / 2.0),
                        camera.cx / (camera.width / 2.0) - 1.0,
                        camera.cy / (camera.height / 2.0) - 1.0};
  c.color_distortion = {};  // the frames' colour images are taken as undistorted
  return c;
}

ReplayDescription replay_from_sequence(const dataset::Sequence& sequence,
                                       const PinholeCamera& camera, const ReplayBuildOptions& o) {
  ReplayDescription d = d455_description(calibration_for(camera));
  d.realtime = o.realtime;
  ReplayNode& depth = d.nodes[0];
  ReplayNode& depth_meta = d.nodes[1];
  ReplayNode& color = d.nodes[3];
  ReplayNode& color_meta = d.nodes[4];
  const StreamMode depth_mode{kFourccZ16, camera.width, camera.height, o.fps};
  const StreamMode color_mode{kFourccYuyv, camera.width, camera.height, o.fps};
  depth.formats = {{kFourccZ16, {{camera.width, camera.height, {o.fps}}}}};
  color.formats = {{kFourccYuyv, {{camera.width, camera.height, {o.fps}}}}};
  depth.frames_mode = depth_mode;
  color.frames_mode = color_mode;
  depth.unplug_after = o.unplug_after;
  color.unplug_after = o.unplug_after;
  const std::size_t n = o.frames == 0 ? sequence.size() : std::min(o.frames, sequence.size());
  const double t0 = sequence.timestamp(0);
  for (std::size_t i = 0; i < n; ++i) {
    if (std::find(o.kernel_drops.begin(), o.kernel_drops.end(), i) != o.kernel_drops.end())
      continue;  // the driver lost it: a gap in the sequence numbers
    const dataset::Frame f = sequence.frame(i);
    if (f.depth.empty()) throw Error("replay: frame " + std::to_string(i) + " has no depth");
    const double t = sequence.timestamp(i) - t0;
    const auto ns = static_cast<std::int64_t>(std::llround((100.0 + t) * 1e9));  // host clock
    const auto seq = static_cast<std::uint32_t>(i);
    FrameMetadata m{
        .host_ns = static_cast<std::uint64_t>(ns),
        .frame_counter = seq,
        .sensor_timestamp_us = static_cast<std::uint32_t>(std::llround(t * 1e6) + 5000000),
        .exposure_us = 8000};
    depth.frames.push_back({z16_bytes(f.depth), seq, ns + 3000000});  // 3 ms transfer latency
    color.frames.push_back({encode_yuyv(f.color), seq, ns + 5000000});
    if (o.metadata) {
      depth_meta.frames.push_back({encode_uvc_metadata(m), seq, ns + 3000000});
      color_meta.frames.push_back({encode_uvc_metadata(m), seq, ns + 5000000});
    }
  }
  if (!o.metadata) {  // after the frames: the references above point into d.nodes
    d.nodes.erase(d.nodes.begin() + 4);
    d.nodes.erase(d.nodes.begin() + 1);
  }
  return d;
}

}  // namespace coloc::capture
