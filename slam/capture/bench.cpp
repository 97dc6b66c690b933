#include "slam/capture/bench.hpp"

#include <opencv2/imgproc.hpp>

#include "slam/capture/formats.hpp"
#include "slam/capture/recorder.hpp"
#include "slam/capture/register.hpp"

namespace coloc::capture {
namespace {

// A depth frame as a D455 sees a room: two walls and a floor, with 5 % holes.
std::vector<std::uint8_t> synthetic_z16(int w, int h, int seed) {
  std::vector<std::uint8_t> out(static_cast<std::size_t>(w) * h * 2);
  cv::RNG rng(static_cast<std::uint64_t>(seed));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double z = x < w / 2 ? 1.5 + 2.5 * x / w : 3.0 - (x - w / 2.0) / w;
      if (y > h * 2 / 3) z = 1.0 + 0.5 * (h - y) / h * 6;
      auto mm =
          static_cast<std::uint16_t>(rng.uniform(0.0, 1.0) < 0.05 ? 0 : z * 1000 + (seed % 7));
      const std::size_t k = 2 * (static_cast<std::size_t>(y) * w + x);
      out[k] = static_cast<std::uint8_t>(mm & 0xff);
      out[k + 1] = static_cast<std::uint8_t>(mm >> 8);
    }
  return out;
}

cv::Mat synthetic_color(int w, int h, int seed) {
  cv::Mat bgr(h, w, CV_8UC3);
  cv::randu(bgr, cv::Scalar::all(0), cv::Scalar::all(255));
  cv::GaussianBlur(bgr, bgr, {7, 7}, 2.0);  // image-like texture, not white noise
  cv::putText(bgr, std::to_string(seed), {w / 3, h / 2}, cv::FONT_HERSHEY_SIMPLEX, 4.0,
              cv::Scalar(255, 255, 255), 6);
  return bgr;
}

}  // namespace

DecodeBench measure_decode_register(int pairs, int dw, int dh, int cw, int ch) {
  const DepthColorCalibration calib = nominal_d455_calibration();
  const DepthRegistrar registrar(calib.depth_camera(dw, dh), calib.color_camera(cw, ch),
                                 calib.color_from_depth);
  std::vector<std::vector<std::uint8_t>> depth, color;
  for (int i = 0; i < 4; ++i) {
    depth.push_back(synthetic_z16(dw, dh, i));
    color.push_back(encode_yuyv(synthetic_color(cw, ch, i)));
  }
  std::vector<double> z16, yuyv, reg, total;
  for (int i = 0; i < pairs; ++i) {
    ThreadCpuStopwatch all, part;
    const cv::Mat raw = decode_z16(depth[i % 4], dw, dh);
    z16.push_back(part.elapsed_ms());
    part.restart();
    const cv::Mat bgr = decode_color(color[i % 4], kFourccYuyv, cw, ch);
    yuyv.push_back(part.elapsed_ms());
    part.restart();
    const cv::Mat registered = registrar.register_raw(raw, 1000.0);
    reg.push_back(part.elapsed_ms());
    total.push_back(all.elapsed_ms());
    if (registered.empty() || bgr.empty()) break;  // keeps the work from being optimized away
  }
  return {dw, dh, cw, ch, summarize(z16), summarize(yuyv), summarize(reg), summarize(total)};
}

WriteBench measure_recorder(const std::filesystem::path& dir, std::size_t frames,
                            unsigned workers) {
  const DepthColorCalibration calib = nominal_d455_calibration();
  const DepthRegistrar registrar(calib.depth_camera(848, 480), calib.color_camera(640, 480),
                                 calib.color_from_depth);
  std::vector<RgbdFrame> pool;
  for (int i = 0; i < 4; ++i) {
    RgbdFrame f;
    f.color = synthetic_color(640, 480, i);
    f.depth_raw = registrar.register_raw(decode_z16(synthetic_z16(848, 480, i), 848, 480), 1000.0);
    pool.push_back(f);
  }
  Recorder recorder(dir, {.camera = calib.color_camera(640, 480), .depth_map_factor = 1000.0},
                    {.png_workers = workers});
  Stopwatch wall;
  for (std::size_t i = 0; i < frames; ++i) {
    RgbdFrame f = pool[i % pool.size()];
    f.timestamp = static_cast<double>(i) / 30.0;
    recorder.add(f);
  }
  recorder.close();
  WriteBench b;
  b.frames = frames;
  b.seconds = wall.elapsed_seconds();
  b.frames_per_second = static_cast<double>(frames) / b.seconds;
  b.megabytes_per_second = static_cast<double>(recorder.stats().bytes) / 1e6 / b.seconds;
  b.workers = workers;
  return b;
}

}  // namespace coloc::capture
