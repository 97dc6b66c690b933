#include "registration/twin/motion.hpp"

#include <algorithm>
#include <cmath>

#include "slam/core/error.hpp"

namespace coloc::registration::twin {
namespace {

// Camera axes in a body frame x forward, y left, z up: cam x = -y, cam y = -z, cam z = x.
Eigen::Matrix3d body_from_cam() {
  Eigen::Matrix3d r;
  r.col(0) = -Eigen::Vector3d::UnitY();
  r.col(1) = -Eigen::Vector3d::UnitZ();
  r.col(2) = Eigen::Vector3d::UnitX();
  return r;
}

double smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3.0 - 2.0 * x);
}

Eigen::Vector3d normal3(std::mt19937_64& rng, double sigma) {
  std::normal_distribution<double> n(0.0, sigma);
  return {n(rng), n(rng), n(rng)};
}

}  // namespace

void WalkOptions::check() const {
  if (!(speed > 0.05 && speed < 5.0))
    throw Error("speed must be in (0.05, 5) m/s", {.field = "speed"});
  if (!(head_height > 0.2)) throw Error("head_height must be > 0.2 m", {.field = "head_height"});
  if (!(look_period > 0.5)) throw Error("look_period must be > 0.5 s", {.field = "look_period"});
}

WalkTrajectory::WalkTrajectory(const std::vector<Eigen::Vector2d>& path, const WalkOptions& options,
                               std::uint64_t seed)
    : options_(options) {
  options_.check();
  if (path.size() < 2) throw Error("walking path needs at least 2 waypoints", {.field = "path"});
  // Resample the polyline every `speed * knot_dt` metres; one knot per second.
  const double spacing = options_.speed * knot_dt_;
  std::vector<Eigen::Vector2d> pts{path.front()};
  double carry = 0.0;
  for (std::size_t k = 0; k + 1 < path.size(); ++k) {
    const Eigen::Vector2d d = path[k + 1] - path[k];
    const double len = d.norm();
    double s = spacing - carry;
    for (; s <= len; s += spacing)
      pts.push_back(path[k] + d * (s / len));
    carry = len - (s - spacing);
  }
  if ((pts.back() - path.back()).norm() > 1e-9) pts.push_back(path.back());
  // Three copies at each end: the walk starts and stops at rest (zero velocity/acceleration).
  control_.assign(3, pts.front());
  control_.insert(control_.end(), pts.begin(), pts.end());
  control_.insert(control_.end(), 2, pts.back());
  duration_ = static_cast<double>(control_.size() - 3) * knot_dt_;
  // The spline leaves the start towards the first resampled point.
  const auto leave = std::find_if(pts.begin(), pts.end(), [&](const Eigen::Vector2d& p) {
    return (p - pts.front()).norm() > 1e-9;
  });
  if (leave != pts.end())
    start_heading_ = std::atan2(leave->y() - pts.front().y(), leave->x() - pts.front().x());
  std::mt19937_64 rng(seed ^ 0x5eed5eedull);
  std::uniform_real_distribution<double> phase(0.0, 2.0 * M_PI);
  for (double& p : phase_)
    p = phase(rng);
}

Eigen::Vector2d WalkTrajectory::spline(double u) const {
  const double umax = static_cast<double>(control_.size() - 3);
  u = std::clamp(u, 0.0, umax);
  const auto k = std::min(static_cast<std::size_t>(u), control_.size() - 4);
  const double s = u - static_cast<double>(k);
  const double s2 = s * s, s3 = s2 * s;
  return ((1 - s) * (1 - s) * (1 - s) * control_[k] + (3 * s3 - 6 * s2 + 4) * control_[k + 1] +
          (-3 * s3 + 3 * s2 + 3 * s + 1) * control_[k + 2] + s3 * control_[k + 3]) /
         6.0;
}

SE3 WalkTrajectory::world_from_cam(double t) const {
  const double tau = std::clamp(t - options_.start_time, 0.0, duration_);
  const double u = tau / knot_dt_;
  const Eigen::Vector2d xy = spline(u);
  const Eigen::Vector2d dir = spline(u + 0.7) - spline(u - 0.7);
  // At rest (the first 0.3 s, while both ends sit on the start's copies) the walker faces the
  // way it will leave: a fixed heading there turned the head by 10 degrees in one frame when the
  // walk set off, where the IMU saw nothing.
  const double heading = dir.norm() > 1e-9 ? std::atan2(dir.y(), dir.x()) : start_heading_;
  const double w = 2.0 * M_PI / options_.look_period;
  const double a = options_.look_amplitude;
  const double yaw =
      heading + a * std::sin(w * tau + phase_[0]) + 0.35 * a * std::sin(2.3 * w * tau + phase_[1]);
  const double pitch = -0.08 + options_.pitch_amplitude * std::sin(1.3 * w * tau + phase_[2]);
  const double roll = 0.04 * std::sin(1.7 * w * tau + phase_[3]);
  const double ramp = smoothstep(tau / 2.0) * smoothstep((duration_ - tau) / 2.0);
  const double z = options_.head_height + options_.bob_amplitude * ramp *
                                              std::sin(2.0 * M_PI * options_.step_frequency * tau);
  const Eigen::Matrix3d r = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(-pitch, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix() *
                            body_from_cam();
  return SE3(SO3::from_matrix(r), Eigen::Vector3d(xy.x(), xy.y(), z));
}

Trajectory sample_trajectory(const WalkTrajectory& walk, double rate, double t0, double t1) {
  Trajectory out;
  for (long k = 0;; ++k) {
    const double t = t0 + static_cast<double>(k) / rate;
    if (t > t1 + 1e-9) break;
    out.push_back({t, walk.world_from_cam(t)});
  }
  return out;
}

void ImuOptions::check() const {
  if (!(rate >= 50.0 && rate <= 1000.0))
    throw Error("IMU rate must be in 50..1000 Hz", {.field = "rate"});
  if (gyro_noise_density < 0 || accel_noise_density < 0 || gyro_random_walk < 0 ||
      accel_random_walk < 0) {
    throw Error("IMU noise parameters must be >= 0", {.field = "noise"});
  }
}

void simulate_imu(const WalkTrajectory& walk, const ImuOptions& options, std::uint64_t seed,
                  std::vector<ImuSample>& measured, std::vector<ImuTruth>& truth) {
  options.check();
  measured.clear();
  truth.clear();
  std::mt19937_64 rng(seed ^ 0x1a2b3c4dull);
  const double dt = 1.0 / options.rate;
  const double h = 1e-3;  // central-difference step, seconds
  const SE3 cam_from_imu = options.imu_from_cam.inverse();
  const auto world_from_imu = [&](double t) { return walk.world_from_cam(t) * cam_from_imu; };
  Eigen::Vector3d bg = normal3(rng, options.initial_gyro_bias);
  Eigen::Vector3d ba = normal3(rng, options.initial_accel_bias);
  const double sg = options.gyro_noise_density * std::sqrt(options.rate);
  const double sa = options.accel_noise_density * std::sqrt(options.rate);
  const Eigen::Vector3d up_g(0.0, 0.0, options.gravity);
  for (long k = 1;; ++k) {
    const double t = walk.start_time() + static_cast<double>(k) * dt;
    if (t > walk.end_time() - dt) break;
    const SE3 a = world_from_imu(t - h), b = world_from_imu(t), c = world_from_imu(t + h);
    ImuTruth tr;
    tr.ideal.timestamp = t;
    tr.ideal.gyro = (a.so3().inverse() * c.so3()).log() / (2.0 * h);
    const Eigen::Vector3d acc =
        (a.translation() - 2.0 * b.translation() + c.translation()) / (h * h);
    tr.ideal.accel = b.so3().inverse() * (acc + up_g);
    tr.gyro_bias = bg;
    tr.accel_bias = ba;
    ImuSample m;
    m.timestamp = t;
    m.gyro = tr.ideal.gyro + bg + normal3(rng, sg);
    m.accel = tr.ideal.accel + ba + normal3(rng, sa);
    measured.push_back(m);
    truth.push_back(tr);
    bg += normal3(rng, options.gyro_random_walk * std::sqrt(dt));
    ba += normal3(rng, options.accel_random_walk * std::sqrt(dt));
  }
}

void HeadsetOptions::check() const {
  if (!(rate >= 10.0 && rate <= 1000.0))
    throw Error("headset rate must be in 10..1000 Hz", {.field = "rate"});
  if (translation_drift < 0 || yaw_drift < 0 || jitter < 0) {
    throw Error("headset drift parameters must be >= 0", {.field = "drift"});
  }
}

HeadsetStreams simulate_headset(const WalkTrajectory& walk, const HeadsetOptions& options,
                                std::uint64_t seed) {
  options.check();
  std::mt19937_64 rng(seed ^ 0x4ead5e7ull);
  std::uniform_real_distribution<double> yaw0(-M_PI, M_PI);
  std::uniform_real_distribution<double> off(-3.0, 3.0);
  // The headset's tracking origin: somewhere near the start, level, at an arbitrary heading.
  const SE3 world_from_xr0(SO3::exp(Eigen::Vector3d(0, 0, yaw0(rng))),
                           Eigen::Vector3d(off(rng), off(rng), 0.0));
  HeadsetStreams out;
  const double dt = 1.0 / options.rate;
  Eigen::Vector3d drift = Eigen::Vector3d::Zero();
  double drift_yaw = 0.0;
  std::normal_distribution<double> n01(0.0, 1.0);
  for (long k = 0;; ++k) {
    const double t = walk.start_time() + static_cast<double>(k) * dt;
    if (t > walk.end_time() + 1e-9) break;
    const SE3 world_from_headset = walk.world_from_cam(t) * options.cam_from_headset;
    const SE3 world_from_xr =
        world_from_xr0 * SE3(SO3::exp(Eigen::Vector3d(0, 0, drift_yaw)), drift);
    SE3 reported = world_from_xr.inverse() * world_from_headset;
    reported.translation() += normal3(rng, options.jitter);
    out.xr_from_headset.push_back({t, reported});
    out.world_from_headset.push_back({t, world_from_headset});
    out.world_from_xr.push_back({t, world_from_xr});
    const double st = options.translation_drift * std::sqrt(dt);
    drift += Eigen::Vector3d(st * n01(rng), st * n01(rng), 0.3 * st * n01(rng));
    drift_yaw += options.yaw_drift * std::sqrt(dt) * n01(rng);
  }
  return out;
}

}  // namespace coloc::registration::twin
