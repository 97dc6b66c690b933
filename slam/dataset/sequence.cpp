#include "slam/dataset/sequence.hpp"

#include <algorithm>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "slam/core/error.hpp"
#include "slam/core/input_file.hpp"

namespace coloc::dataset {

std::vector<ImuSample> Sequence::imu_between(double t0, double t1) const {
  const auto& all = imu();
  auto lo = std::upper_bound(all.begin(), all.end(), t0,
                             [](double t, const ImuSample& s) { return t < s.timestamp; });
  auto hi = std::upper_bound(lo, all.end(), t1,
                             [](double t, const ImuSample& s) { return t < s.timestamp; });
  return {lo, hi};
}

std::unique_ptr<Sequence> open_sequence(const std::filesystem::path& dir,
                                        const SequenceOptions& options) {
  if (!std::filesystem::is_directory(dir)) {
    throw Error("sequence folder not found", {.file = dir.string()});
  }
  if (std::filesystem::exists(dir / "rgb.txt") ||
      std::filesystem::exists(dir / "associations.txt")) {
    return open_tum(dir, options);
  }
  if (std::filesystem::exists(dir / "frame-000000.color.png") ||
      std::filesystem::exists(dir / "frame-000000.color.jpg")) {
    return open_seven_scenes(dir, options);
  }
  if (std::filesystem::exists(dir / "mav0") || std::filesystem::exists(dir / "cam0" / "data.csv")) {
    return open_euroc(dir, options);
  }
  throw Error(
      "unknown sequence layout (expected TUM rgb.txt/associations.txt, 7-Scenes "
      "frame-000000.color.*, or EuRoC mav0/)",
      {.file = dir.string()});
}

cv::Mat read_image(const std::filesystem::path& path, bool grey) {
  check_input_file(path, "image");
  cv::Mat img = cv::imread(path.string(), grey ? cv::IMREAD_GRAYSCALE : cv::IMREAD_COLOR);
  if (img.empty()) throw Error("cannot read image", {.file = path.string()});
  return img;
}

cv::Mat to_camera_order(const cv::Mat& bgr, bool rgb_order) {
  if (!rgb_order || bgr.channels() != 3) return bgr;
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  return rgb;
}

cv::Mat read_depth(const std::filesystem::path& path, double units_per_metre,
                   unsigned invalid_raw) {
  check_input_file(path, "depth image");
  cv::Mat raw = cv::imread(path.string(), cv::IMREAD_ANYDEPTH);
  if (raw.empty()) throw Error("cannot read depth image", {.file = path.string()});
  if (raw.type() != CV_16UC1) {
    throw Error("depth image is not 16-bit single-channel", {.file = path.string()});
  }
  if (invalid_raw != 0) raw.setTo(0, raw == invalid_raw);
  cv::Mat depth;
  raw.convertTo(depth, CV_32FC1, 1.0 / units_per_metre);
  return depth;
}

}  // namespace coloc::dataset
