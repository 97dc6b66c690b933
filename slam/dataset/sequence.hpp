#pragma once
// Recorded sequences behind one interface. Frames are loaded lazily (frame(i) reads the images
// from disk), so a sequence of any length costs only its index in memory.
//
// Conventions: timestamps in seconds; depth in metres as CV_32FC1 with 0 where invalid;
// ground truth as world_from_cam (camera-to-world) in the dataset's world frame.

#include <Eigen/Core>
#include <filesystem>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "slam/core/camera.hpp"
#include "slam/core/imu_sample.hpp"
#include "slam/core/trajectory.hpp"

namespace coloc::dataset {

using coloc::ImuSample;

struct Frame {
  std::size_t index = 0;
  double timestamp = 0.0;  // seconds (of the colour image)
  cv::Mat color;           // 8UC3 BGR, or 8UC1 for grey cameras
  cv::Mat depth;           // CV_32FC1 metres, 0 = invalid; empty when the dataset has none
  cv::Mat right;           // second camera of a stereo pair (EuRoC cam1), else empty
  std::filesystem::path color_path;
  std::filesystem::path depth_path;
};

class Sequence {
 public:
  virtual ~Sequence() = default;

  // The folder the sequence was opened from (what errors about the sequence name).
  const std::filesystem::path& folder() const { return folder_; }

  virtual std::string format() const = 0;  // "tum", "7scenes", "euroc"
  virtual std::size_t size() const = 0;
  virtual double timestamp(std::size_t index) const = 0;
  // Loads frame `index` from disk; throws coloc::Error naming the file when it cannot be read.
  virtual Frame frame(std::size_t index) const = 0;
  // Ground truth (empty when the dataset has none).
  virtual const Trajectory& ground_truth() const = 0;
  // All IMU samples, time-ordered (empty when there is no IMU).
  virtual const std::vector<ImuSample>& imu() const = 0;
  // Intrinsics when the dataset itself states them (EuRoC sensor.yaml, 7-Scenes); otherwise
  // they come from a settings file.
  virtual std::optional<Camera> camera() const = 0;

  // IMU samples with t0 < t <= t1.
  std::vector<ImuSample> imu_between(double t0, double t1) const;

 protected:
  explicit Sequence(std::filesystem::path folder) : folder_(std::move(folder)) {}

 private:
  std::filesystem::path folder_;
};

struct SequenceOptions {
  // Raw depth units per metre; 0 = the format's default (TUM 5000, 7-Scenes 1000).
  double depth_scale = 0.0;
  // TUM without associations.txt: maximal rgb/depth time difference (seconds).
  double max_association_dt = 0.02;
  // TUM: this associations file ("t_rgb rgb t_depth depth", paths relative to the folder)
  // instead of the folder's own (ORB-SLAM's rgbd_tum takes it as an argument).
  std::filesystem::path associations;
};

// Detects the format from the folder's files (rgb.txt -> TUM, frame-000000.color.* ->
// 7-Scenes, mav0/ or cam0/data.csv -> EuRoC). Throws coloc::Error when none matches.
std::unique_ptr<Sequence> open_sequence(const std::filesystem::path& dir,
                                        const SequenceOptions& options = {});

std::unique_ptr<Sequence> open_tum(const std::filesystem::path& dir,
                                   const SequenceOptions& options = {});
std::unique_ptr<Sequence> open_seven_scenes(const std::filesystem::path& dir,
                                            const SequenceOptions& options = {});
std::unique_ptr<Sequence> open_euroc(const std::filesystem::path& dir,
                                     const SequenceOptions& options = {});

// Reads a colour/grey image (8-bit) or throws coloc::Error naming the file.
cv::Mat read_image(const std::filesystem::path& path, bool grey = false);
// Images decoded from files are BGR; a camera whose settings say Camera.RGB: 1 hands RGB images
// to tracking. Returns `bgr` in the camera's order (an RGB copy when `rgb_order`; grey as it is).
cv::Mat to_camera_order(const cv::Mat& bgr, bool rgb_order);
// Reads a 16-bit depth PNG into metres (CV_32FC1); raw values of 0 and of `invalid_raw` (if
// non-zero) become 0. Throws coloc::Error naming the file.
cv::Mat read_depth(const std::filesystem::path& path, double units_per_metre,
                   unsigned invalid_raw = 0);

}  // namespace coloc::dataset
