#include "slam/mapping/gravity.hpp"

#include <algorithm>
#include <cmath>

#include "slam/core/error.hpp"
#include "slam/core/so3.hpp"

namespace coloc::slam::mapping {

void GravityOptions::check() const {
  if (!(half_window > 0.0)) throw Error("GravityOptions.half_window must be > 0");
  if (!(velocity_half_window > 0.0)) throw Error("GravityOptions.velocity_half_window must be > 0");
  if (!(max_sample_gap > 0.0)) throw Error("GravityOptions.max_sample_gap must be > 0");
  if (!(max_frame_gap > 0.0)) throw Error("GravityOptions.max_frame_gap must be > 0");
  if (!(model.magnitude > 0.0)) throw Error("GravityOptions.model.magnitude must be > 0");
  if (!(model.sigma > 0.0)) throw Error("GravityOptions.model.sigma must be > 0");
  if (!(model.accel_bias_sigma > 0.0))
    throw Error("GravityOptions.model.accel_bias_sigma must be > 0");
}

GravityMeasurements::GravityMeasurements(std::vector<ImuSample> imu, const SE3& imu_from_cam,
                                         Trajectory frames, const GravityOptions& options)
    : imu_(std::move(imu)),
      cam_from_imu_(imu_from_cam.so3().inverse()),
      frames_(std::move(frames)),
      options_(options) {
  options_.check();
  auto by_time = [](const auto& a, const auto& b) { return a.timestamp < b.timestamp; };
  std::stable_sort(imu_.begin(), imu_.end(), by_time);
  std::stable_sort(frames_.begin(), frames_.end(), by_time);
  // What an accelerometer at the camera's origin would read: f + alpha x t + omega x (omega x t)
  // in the IMU frame, alpha by central differences of the gyro.
  const Eigen::Vector3d arm = imu_from_cam.translation();
  if (arm.isZero() || imu_.size() < 3) return;
  std::vector<Eigen::Vector3d> moved(imu_.size());
  for (std::size_t i = 0; i < imu_.size(); ++i) {
    const ImuSample& before = imu_[i == 0 ? 0 : i - 1];
    const ImuSample& after = imu_[std::min(i + 1, imu_.size() - 1)];
    const double dt = after.timestamp - before.timestamp;
    const Eigen::Vector3d alpha =
        dt > 0.0 ? Eigen::Vector3d((after.gyro - before.gyro) / dt) : Eigen::Vector3d::Zero();
    const Eigen::Vector3d& omega = imu_[i].gyro;
    moved[i] = imu_[i].accel + alpha.cross(arm) + omega.cross(omega.cross(arm));
  }
  for (std::size_t i = 0; i < imu_.size(); ++i)
    imu_[i].accel = moved[i];
}

std::optional<Eigen::Vector3d> GravityMeasurements::position(double t) const {
  const auto after =
      std::lower_bound(frames_.begin(), frames_.end(), t,
                       [](const StampedPose& p, double v) { return p.timestamp < v; });
  if (after == frames_.end() || after == frames_.begin()) {
    if (after != frames_.end() && after->timestamp == t) return after->world_from_cam.translation();
    return std::nullopt;
  }
  const StampedPose& a = *(after - 1);
  const StampedPose& b = *after;
  // A lost stretch (no poses) is not bridged by a straight line (max_frame_gap).
  if (b.timestamp - a.timestamp > options_.max_frame_gap) return std::nullopt;
  const double s = (t - a.timestamp) / (b.timestamp - a.timestamp);
  return (1.0 - s) * a.world_from_cam.translation() + s * b.world_from_cam.translation();
}

std::optional<Eigen::Vector3d> GravityMeasurements::velocity(double t) const {
  const double d = options_.velocity_half_window;
  const auto before = position(t - d);
  const auto after = position(t + d);
  if (!before || !after) return std::nullopt;
  return (*after - *before) / (2.0 * d);
}

std::optional<Eigen::Vector3d> GravityMeasurements::mean_force(double t) const {
  const double w = options_.half_window;
  const auto first = std::lower_bound(imu_.begin(), imu_.end(), t - w,
                                      [](const ImuSample& s, double v) { return s.timestamp < v; });
  const auto last = std::upper_bound(imu_.begin(), imu_.end(), t + w,
                                     [](double v, const ImuSample& s) { return v < s.timestamp; });
  if (last - first < 2) return std::nullopt;
  const double gap = options_.max_sample_gap;
  if (first->timestamp - (t - w) > gap || (t + w) - (last - 1)->timestamp > gap)
    return std::nullopt;
  // Orientations relative to a sample next to t, by integrating the gyro both ways:
  // imu(t)_from_imu(ti+1) = imu(t)_from_imu(ti) * exp(gyro_i * dt).
  const auto centre =
      std::min(std::lower_bound(first, last, t,
                                [](const ImuSample& s, double v) { return s.timestamp < v; }),
               last - 1);
  Eigen::Vector3d sum = centre->accel;
  SO3 rot;
  for (auto it = centre; it + 1 != last; ++it) {
    const double dt = (it + 1)->timestamp - it->timestamp;
    if (dt > gap) return std::nullopt;
    rot = rot * SO3::exp(it->gyro * dt);
    sum += rot * (it + 1)->accel;
  }
  rot = SO3();
  for (auto it = centre; it != first; --it) {
    const double dt = it->timestamp - (it - 1)->timestamp;
    if (dt > gap) return std::nullopt;
    rot = rot * SO3::exp(-(it - 1)->gyro * dt);
    sum += rot * (it - 1)->accel;
  }
  // From the centre sample's frame to the frame at t (up to half a sample period apart: 2.5 ms
  // at 200 Hz, 2.5 mrad at 1 rad/s).
  return SO3::exp(centre->gyro * (centre->timestamp - t)) *
         (sum / static_cast<double>(last - first));
}

std::optional<optim::BundleProblem::Gravity> GravityMeasurements::at(double timestamp) const {
  const double w = options_.half_window;
  const auto force = mean_force(timestamp);
  const auto v0 = velocity(timestamp - w);
  const auto v1 = velocity(timestamp + w);
  if (!force || !v0 || !v1) return std::nullopt;
  optim::BundleProblem::Gravity g;
  g.specific_force_cam = cam_from_imu_ * *force;
  g.accel_world = (*v1 - *v0) / (2.0 * w);
  return g;
}

}  // namespace coloc::slam::mapping
