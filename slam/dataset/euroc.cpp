// EuRoC / ASL layout: mav0/cam0/{data.csv,data/,sensor.yaml}, mav0/cam1/..., mav0/imu0/data.csv
// (t[ns], gyro xyz [rad/s], accel xyz [m/s^2]). Ground truth from
// mav0/state_groundtruth_estimate0/data.csv (body = IMU frame; turned into the left camera's
// pose with cam0's T_BS) or, as ORB-SLAM3 distributes it, a "<name>_GT_*.txt" file in the
// sequence folder already in the left camera frame (t[ns],px,py,pz,qw,qx,qy,qz). In that file
// the quaternion is the conjugate of world_from_cam's rotation (checked two ways on V1_01: with
// it conjugated the camera's y axis points down along gravity and the rotation rates match the
// gyroscope; taken as written, neither holds), so it is conjugated on reading.

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>

#include "slam/core/error.hpp"
#include "slam/core/input_file.hpp"
#include "slam/core/yaml_text.hpp"
#include "slam/dataset/sequence.hpp"
#include "slam/dataset/text_table.hpp"

namespace coloc::dataset {
namespace {

struct CameraInfo {
  PinholeCamera camera;
  SE3 body_from_cam;
};

namespace {

CameraInfo read_sensor_text(const std::filesystem::path& file) {
  // Through the YAML guard (OpenCV's reader can loop forever on some malformed input).
  const std::string text = read_yaml_text(file, "sensor YAML");
  cv::FileStorage fs;
  try {
    fs.open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY);
  } catch (const cv::Exception& e) {
    throw Error("not a readable YAML file (" + std::string(e.err) + ")", {.file = file.string()});
  }
  if (!fs.isOpened()) throw Error("cannot open", {.file = file.string()});
  auto numbers = [&](const char* key, std::size_t min_count) {
    std::vector<double> v;
    const cv::FileNode node = fs[key];
    if (node.isSeq()) {
      for (const auto& n : node)
        v.push_back(static_cast<double>(n));
    }
    if (v.size() < min_count) {
      throw Error("expected at least " + std::to_string(min_count) + " numbers",
                  {.file = file.string(), .field = key});
    }
    return v;
  };
  const auto k = numbers("intrinsics", 4);
  const auto res = numbers("resolution", 2);
  const auto d = numbers("distortion_coefficients", 4);
  CameraInfo info;
  info.camera = {static_cast<int>(res[0]),
                 static_cast<int>(res[1]),
                 k[0],
                 k[1],
                 k[2],
                 k[3],
                 {d[0], d[1], d[2], d[3], d.size() > 4 ? d[4] : 0.0}};
  std::vector<double> t;
  const cv::FileNode data = fs["T_BS"]["data"];
  for (const auto& n : data)
    t.push_back(static_cast<double>(n));
  if (t.size() != 16) throw Error("expected 16 numbers", {.file = file.string(), .field = "T_BS"});
  info.body_from_cam =
      SE3::from_matrix(Eigen::Map<Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(t.data()));
  return info;
}

}  // namespace

CameraInfo read_sensor_yaml(const std::filesystem::path& file) {
  return read_naming_file(file, "sensor YAML", [&] { return read_sensor_text(file); });
}

double ns_to_s(const std::filesystem::path& file, const TextRow& row) {
  return parse_double(file, row, 0) * 1e-9;
}

class EurocSequence final : public Sequence {
 public:
  explicit EurocSequence(const std::filesystem::path& dir) : Sequence(dir) {
    root_ = std::filesystem::exists(dir / "mav0") ? dir / "mav0" : dir;
    read_camera_list(root_ / "cam0" / "data.csv", &left_);
    if (left_.empty()) throw Error("no frames", {.file = (root_ / "cam0" / "data.csv").string()});
    if (std::filesystem::exists(root_ / "cam1" / "data.csv")) {
      read_camera_list(root_ / "cam1" / "data.csv", &right_);
    }
    if (std::filesystem::exists(root_ / "cam0" / "sensor.yaml")) {
      cam0_ = read_sensor_yaml(root_ / "cam0" / "sensor.yaml");
    }
    if (std::filesystem::exists(root_ / "imu0" / "data.csv")) read_imu(root_ / "imu0" / "data.csv");
    read_ground_truth(dir);
  }

  std::string format() const override { return "euroc"; }
  std::size_t size() const override { return left_.size(); }
  double timestamp(std::size_t i) const override { return left_.at(i).first; }
  const Trajectory& ground_truth() const override { return ground_truth_; }
  const std::vector<ImuSample>& imu() const override { return imu_; }
  std::optional<Camera> camera() const override {
    if (!cam0_) return std::nullopt;
    return cam0_->camera;
  }

  Frame frame(std::size_t i) const override {
    Frame f;
    f.index = i;
    f.timestamp = left_.at(i).first;
    f.color_path = root_ / "cam0" / "data" / left_[i].second;
    f.color = read_image(f.color_path, true);
    // cam1 is hardware-synchronized: pair by the nearest timestamp within 1 ms.
    auto it = std::lower_bound(right_.begin(), right_.end(), f.timestamp - 1e-3,
                               [](const auto& e, double t) { return e.first < t; });
    if (it != right_.end() && std::abs(it->first - f.timestamp) <= 1e-3) {
      f.right = read_image(root_ / "cam1" / "data" / it->second, true);
    }
    return f;
  }

 private:
  static void read_camera_list(const std::filesystem::path& file,
                               std::vector<std::pair<double, std::string>>* out) {
    for (const auto& row : read_text_table(file)) {
      if (row.fields.size() < 2) {
        throw Error("expected 'timestamp_ns,filename'", {.file = file.string(), .line = row.line});
      }
      out->emplace_back(ns_to_s(file, row), row.fields[1]);
    }
  }

  void read_imu(const std::filesystem::path& file) {
    for (const auto& row : read_text_table(file)) {
      ImuSample s;
      s.timestamp = ns_to_s(file, row);
      for (int k = 0; k < 3; ++k) {
        s.gyro(k) = parse_double(file, row, 1 + k);
        s.accel(k) = parse_double(file, row, 4 + k);
      }
      imu_.push_back(s);
    }
  }

  void read_ground_truth(const std::filesystem::path& dir) {
    for (const auto& entry : std::filesystem::directory_iterator(dir)) {
      const std::string name = entry.path().filename().string();
      if (entry.is_regular_file() && name.find("_GT") != std::string::npos &&
          entry.path().extension() == ".txt") {
        read_pose_csv(entry.path(), SE3(), /*conjugate_rotation=*/true);
        return;
      }
    }
    const auto state = root_ / "state_groundtruth_estimate0" / "data.csv";
    if (std::filesystem::exists(state) && cam0_) read_pose_csv(state, cam0_->body_from_cam, false);
  }

  // t[ns], p xyz, q wxyz; each pose is right-multiplied by frame_from_cam.
  void read_pose_csv(const std::filesystem::path& file, const SE3& frame_from_cam,
                     bool conjugate_rotation) {
    for (const auto& row : read_text_table(file)) {
      double v[8];
      for (int k = 0; k < 8; ++k)
        v[k] = parse_double(file, row, k);
      Eigen::Quaterniond q(v[4], v[5], v[6], v[7]);
      if (conjugate_rotation) q = q.conjugate();
      const SE3 world_from_frame(q, Eigen::Vector3d(v[1], v[2], v[3]));
      ground_truth_.push_back({v[0] * 1e-9, world_from_frame * frame_from_cam});
    }
    std::stable_sort(ground_truth_.begin(), ground_truth_.end(),
                     [](const auto& a, const auto& b) { return a.timestamp < b.timestamp; });
  }

  std::filesystem::path root_;
  std::vector<std::pair<double, std::string>> left_;
  std::vector<std::pair<double, std::string>> right_;
  std::optional<CameraInfo> cam0_;
  std::vector<ImuSample> imu_;
  Trajectory ground_truth_;
};

}  // namespace

std::unique_ptr<Sequence> open_euroc(const std::filesystem::path& dir,
                                     const SequenceOptions& /*options*/) {
  return std::make_unique<EurocSequence>(dir);
}

}  // namespace coloc::dataset
