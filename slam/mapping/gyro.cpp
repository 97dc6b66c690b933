#include "slam/mapping/gyro.hpp"

#include <algorithm>
#include <cmath>

#include "slam/core/error.hpp"

namespace coloc::slam::mapping {

void GyroOptions::check() const {
  if (!(max_sample_gap > 0.0)) throw Error("GyroOptions.max_sample_gap must be > 0");
  if (!(max_interval > 0.0)) throw Error("GyroOptions.max_interval must be > 0");
  if (!(model.noise_density > 0.0)) throw Error("GyroOptions.model.noise_density must be > 0");
  if (!(model.random_walk > 0.0)) throw Error("GyroOptions.model.random_walk must be > 0");
  if (!(model.bias_sigma > 0.0)) throw Error("GyroOptions.model.bias_sigma must be > 0");
}

GyroMeasurements::GyroMeasurements(std::vector<ImuSample> imu, const SE3& imu_from_cam,
                                   const GyroOptions& options)
    : imu_(std::move(imu)), cam_from_imu_(imu_from_cam.so3().inverse()), options_(options) {
  options_.check();
  std::stable_sort(imu_.begin(), imu_.end(), [](const ImuSample& a, const ImuSample& b) {
    return a.timestamp < b.timestamp;
  });
}

std::optional<optim::BundleProblem::Gyro> GyroMeasurements::between(double t_a, double t_b) const {
  if (!(t_b > t_a) || t_b - t_a > options_.max_interval) return std::nullopt;
  // The sample in force at t_a is the last one at or before it.
  auto it = std::upper_bound(imu_.begin(), imu_.end(), t_a,
                             [](double v, const ImuSample& s) { return v < s.timestamp; });
  if (it == imu_.begin()) return std::nullopt;
  --it;
  const double gap = options_.max_sample_gap;
  if (t_a - it->timestamp > gap) return std::nullopt;
  // imu(t_a)_from_imu(t) and d log / d bias, accumulated piece by piece:
  //   R <- R exp(w dt),  J <- exp(w dt)^T J - Jr(w dt) dt,
  // w the rate at the piece's middle, linear between samples (holding a sample's rate for its
  // whole period would be off by half a period of the rate's change: 1 mrad over 0.4 s of a
  // 1.2 rad/s^2 turn at 200 Hz).
  SO3 rotation;
  Eigen::Matrix3d jacobian = Eigen::Matrix3d::Zero();
  double t = t_a;
  while (t < t_b) {
    const auto next = it + 1;
    if (next == imu_.end()) return std::nullopt;  // the log ends before t_b
    const double span = next->timestamp - it->timestamp;
    if (span > gap) return std::nullopt;  // a hole in the log
    const double end = std::min(next->timestamp, t_b);
    const double dt = end - t;
    if (dt > 0.0) {
      const double s = span > 0.0 ? (0.5 * (t + end) - it->timestamp) / span : 0.0;
      const Eigen::Vector3d step = ((1.0 - s) * it->gyro + s * next->gyro) * dt;
      const SO3 turn = SO3::exp(step);
      jacobian = turn.inverse().matrix() * jacobian - SO3::right_jacobian(step) * dt;
      rotation = rotation * turn;
    }
    t = end;
    if (t < t_b) it = next;
  }
  optim::BundleProblem::Gyro g;
  g.cam_a_from_cam_b = cam_from_imu_ * rotation * cam_from_imu_.inverse();
  // exp(J b_imu) in the IMU frame is exp(R_ci J R_ic b_cam) in the camera's.
  const Eigen::Matrix3d r = cam_from_imu_.matrix();
  g.bias_jacobian = r * jacobian * r.transpose();
  g.dt = t_b - t_a;
  return g;
}

}  // namespace coloc::slam::mapping
