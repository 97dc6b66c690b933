#pragma once
// An in-memory RGB-D sequence for the capture tests: textured colour and a sloped depth plane,
// 640x480 (a resolution the D4xx tables know), timestamps at 30 Hz.
#include <filesystem>
#include <fstream>
#include <opencv2/imgproc.hpp>
#include <string>

#include "slam/dataset/sequence.hpp"

namespace coloc::capture::testing {

// A sysfs attribute file as the kernel shows it: the text and a newline (parents created).
inline void write_sysfs_file(const std::filesystem::path& p, const std::string& text) {
  std::filesystem::create_directories(p.parent_path());
  std::ofstream(p) << text << "\n";
}

inline PinholeCamera test_camera() {
  return {640, 480, 600.0, 600.0, 319.5, 239.5, {}};
}

class MemorySequence final : public dataset::Sequence {
 public:
  explicit MemorySequence(std::size_t n) : Sequence("memory"), n_(n) {}
  std::string format() const override { return "tum"; }
  std::size_t size() const override { return n_; }
  double timestamp(std::size_t i) const override { return 1000.0 + static_cast<double>(i) / 30.0; }
  dataset::Frame frame(std::size_t i) const override {
    dataset::Frame f;
    f.index = i;
    f.timestamp = timestamp(i);
    f.color = cv::Mat(480, 640, CV_8UC3);
    for (int y = 0; y < 480; ++y)
      for (int x = 0; x < 640; ++x)
        f.color.at<cv::Vec3b>(y, x) =
            cv::Vec3b(static_cast<uchar>((x + 3 * i) % 256), static_cast<uchar>(y % 256),
                      static_cast<uchar>(((x / 16 + y / 16) % 2) * 200));
    f.depth = cv::Mat(480, 640, CV_32FC1);
    for (int y = 0; y < 480; ++y)
      for (int x = 0; x < 640; ++x)
        f.depth.at<float>(y, x) =
            1.0f + 0.002f * static_cast<float>(y) + 0.001f * static_cast<float>(i);
    return f;
  }
  const Trajectory& ground_truth() const override { return gt_; }
  const std::vector<dataset::ImuSample>& imu() const override { return imu_; }
  std::optional<Camera> camera() const override { return test_camera(); }

 private:
  std::size_t n_;
  Trajectory gt_;
  std::vector<dataset::ImuSample> imu_;
};

}  // namespace coloc::capture::testing
