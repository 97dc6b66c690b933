#pragma once
// A D4xx RGB-D camera read over V4L2: the device found (auto, a /dev/videoN of it, or a
// DeviceSystem the caller gives), its factory calibration read over the hardware monitor (or
// `calibration_file`), depth and colour configured and streamed by one thread per node (and
// one per metadata node), frames paired by time, decoded, and depth registered to colour.
// next() runs on the caller's thread; stop() may be called from any thread, and by several.
#include <atomic>
#include <filesystem>
#include <memory>
#include <mutex>
#include <opencv2/core/mat.hpp>

#include "slam/capture/calibration.hpp"
#include "slam/capture/discovery.hpp"
#include "slam/capture/formats.hpp"
#include "slam/capture/pairing.hpp"
#include "slam/capture/register.hpp"
#include "slam/capture/stream.hpp"

namespace coloc::capture {

struct CameraOptions {
  std::string device = "auto";  // "auto" or any /dev/videoN of the camera
  StreamMode depth{kFourccZ16, 848, 480, 30};
  StreamMode color{kFourccYuyv, 640, 480, 30};
  std::filesystem::path calibration_file;  // instead of the factory tables
  double depth_units_per_metre = 1000.0;   // D4xx default depth unit: 1 mm
  double max_pair_dt = 0.017;              // seconds: half a frame at 30 fps
  unsigned buffers = 4;                    // mmap buffers per node
  std::size_t queue_capacity = 8;          // frames per stream waiting for the consumer

  // Throws coloc::Error naming the field.
  void check() const;
};

// "848x480@30" etc. for depth/colour `--mode depth=WxH@FPS,color=WxH@FPS`; throws coloc::Error.
void parse_mode(const std::string& text, CameraOptions& options);

struct RgbdFrame {
  double timestamp = 0.0;  // seconds, of the colour frame (camera clock anchored at the host)
  double depth_timestamp = 0.0;
  cv::Mat color;              // CV_8UC3 BGR
  cv::Mat depth_raw;          // CV_16UC1 registered to colour, depth units (0 = none)
  bool sensor_clock = false;  // timestamps from the UVC metadata (else kernel timestamps)
};

struct CaptureStats {
  StreamCounters depth, color;
  PairingCounters pairing;
  std::size_t metadata_missing = 0;  // frames whose metadata never came (kernel time used)
};

class RgbdCamera {
 public:
  // Throws DeviceError / coloc::Error with what to do (no camera, busy, permissions, mode,
  // calibration unreadable -> `--calibration FILE`).
  RgbdCamera(DeviceSystem& system, const CameraOptions& options);
  ~RgbdCamera();
  RgbdCamera(const RgbdCamera&) = delete;
  RgbdCamera& operator=(const RgbdCamera&) = delete;

  // The next registered pair; nothing when the camera ended (unplugged, stop(), end of a
  // replay) and everything captured before was returned.
  std::optional<RgbdFrame> next();
  void stop();

  // Statistics so far; call from the thread that calls next().
  CaptureStats stats() const;
  // A host CLOCK_MONOTONIC time (seconds; V4L2 and iio timestamps) on the frames' clock, by the
  // latest offset between the depth stream's kernel and sensor timestamps (unchanged without
  // metadata). Call from the thread that calls next().
  double frame_time_of_host(double host_s) const;
  // Why the camera ended by itself ("camera unplugged ..."), if it did.
  std::optional<std::string> end_reason() const;
  bool unplugged() const;

  const RealSenseDevice& device() const { return device_; }
  const DepthColorCalibration& calibration() const { return calibration_; }
  const PinholeCamera& color_camera() const { return color_camera_; }
  const PinholeCamera& depth_camera() const { return depth_camera_; }
  const CameraOptions& options() const { return options_; }

 private:
  struct StreamState;
  double frame_time(StreamState& stream, const RawFrame& frame);
  RgbdFrame decode(const RawFrame& depth, const RawFrame& color, double td, double tc);

  CameraOptions options_;
  RealSenseDevice device_;
  DepthColorCalibration calibration_;
  PinholeCamera depth_camera_, color_camera_;
  std::unique_ptr<DepthRegistrar> registrar_;
  std::unique_ptr<StreamState> depth_, color_;
  FramePairer<RawFrame> pairer_;
  SensorClock sensor_clock_;
  std::optional<double> anchor_s_;  // host time of the first frame
  std::size_t metadata_missing_ = 0;
};

// The camera `device` names in `system` ("auto": the first RealSense with depth and colour).
// Throws coloc::Error with no_camera_advice() when there is none.
RealSenseDevice find_camera(DeviceSystem& system, const std::string& device);

// Reads the factory calibration through the depth node's hardware monitor. Throws coloc::Error
// naming the fallback (--calibration FILE) when the query or the tables fail.
DepthColorCalibration read_factory_calibration(VideoNode& depth_node);

}  // namespace coloc::capture
