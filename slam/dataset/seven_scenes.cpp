// Microsoft 7-Scenes layout: frame-NNNNNN.color.{png,jpg}, frame-NNNNNN.depth.png (millimetres,
// 65535 = invalid), frame-NNNNNN.pose.txt (4x4 camera-to-world). Colour and depth are NOT
// registered to each other (different sensors of a Kinect v1); the dataset has no timestamps,
// so frames are stamped at the Kinect's 30 Hz.

#include <cstdio>
#include <fstream>

#include "slam/core/error.hpp"
#include "slam/dataset/sequence.hpp"
#include "slam/dataset/text_table.hpp"

namespace coloc::dataset {
namespace {

constexpr double kFrameRate = 30.0;
constexpr unsigned kInvalidDepth = 65535;

std::string frame_stem(std::size_t i) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "frame-%06zu", i);
  return buf;
}

Eigen::Matrix4d read_matrix4(const std::filesystem::path& file) {
  const auto rows = read_text_table(file);
  if (rows.size() < 4) throw Error("expected a 4x4 matrix", {.file = file.string()});
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c)
      m(r, c) = parse_double(file, rows[r], c);
  }
  return m;
}

class SevenScenesSequence final : public Sequence {
 public:
  SevenScenesSequence(const std::filesystem::path& dir, const SequenceOptions& options)
      : Sequence(dir), dir_(dir), scale_(options.depth_scale > 0.0 ? options.depth_scale : 1000.0) {
    extension_ =
        std::filesystem::exists(dir / "frame-000000.color.png") ? ".color.png" : ".color.jpg";
    while (std::filesystem::exists(dir / (frame_stem(count_) + extension_)))
      ++count_;
    if (count_ == 0) throw Error("no frame-000000.color.* found", {.file = dir.string()});
    for (std::size_t i = 0; i < count_; ++i) {
      const auto pose_file = dir / (frame_stem(i) + ".pose.txt");
      if (!std::filesystem::exists(pose_file)) break;
      ground_truth_.push_back({timestamp(i), SE3::from_matrix(read_matrix4(pose_file))});
    }
    // The published intrinsics (the dataset's own file, when present, overrides them).
    PinholeCamera cam{640, 480, 585.0, 585.0, 320.0, 240.0, {}};
    if (std::filesystem::exists(dir / "camera-intrinsics.txt")) {
      const auto file = dir / "camera-intrinsics.txt";
      const auto rows = read_text_table(file);
      if (rows.size() < 2) throw Error("expected a 3x3 matrix", {.file = file.string()});
      cam.fx = parse_double(file, rows[0], 0);
      cam.cx = parse_double(file, rows[0], 2);
      cam.fy = parse_double(file, rows[1], 1);
      cam.cy = parse_double(file, rows[1], 2);
    }
    camera_ = cam;
  }

  std::string format() const override { return "7scenes"; }
  std::size_t size() const override { return count_; }
  double timestamp(std::size_t i) const override { return static_cast<double>(i) / kFrameRate; }
  const Trajectory& ground_truth() const override { return ground_truth_; }
  const std::vector<ImuSample>& imu() const override { return imu_; }
  std::optional<Camera> camera() const override { return camera_; }

  Frame frame(std::size_t i) const override {
    if (i >= count_) throw Error("frame index " + std::to_string(i) + " out of range");
    Frame f;
    f.index = i;
    f.timestamp = timestamp(i);
    f.color_path = dir_ / (frame_stem(i) + extension_);
    f.depth_path = dir_ / (frame_stem(i) + ".depth.png");
    f.color = read_image(f.color_path);
    f.depth = read_depth(f.depth_path, scale_, kInvalidDepth);
    return f;
  }

 private:
  std::filesystem::path dir_;
  double scale_;
  std::string extension_;
  std::size_t count_ = 0;
  Trajectory ground_truth_;
  std::vector<ImuSample> imu_;
  Camera camera_;
};

}  // namespace

std::unique_ptr<Sequence> open_seven_scenes(const std::filesystem::path& dir,
                                            const SequenceOptions& options) {
  return std::make_unique<SevenScenesSequence>(dir, options);
}

}  // namespace coloc::dataset
