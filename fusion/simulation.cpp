#include "fusion/simulation.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <random>
#include <sstream>
#include <string>

#include "slam/core/error.hpp"
#include "slam/core/input_file.hpp"
#include "slam/core/timing.hpp"

namespace coloc::fusion {
namespace {

constexpr double kOmega = 0.15;  // rad/s of the figure-eight: ~1.2 m/s walking speed

SO3 yaw_pitch_roll(double yaw, double pitch, double roll) {
  return SO3::from_axis_angle(Eigen::Vector3d::UnitZ(), yaw) *
         SO3::from_axis_angle(Eigen::Vector3d::UnitY(), pitch) *
         SO3::from_axis_angle(Eigen::Vector3d::UnitX(), roll);
}

Eigen::Vector3d gaussian3(std::mt19937& rng, double sigma) {
  std::normal_distribution<double> n(0.0, sigma);
  return {n(rng), n(rng), n(rng)};
}

Eigen::Vector3d random_unit(std::mt19937& rng) {
  Eigen::Vector3d v = gaussian3(rng, 1.0);
  while (v.norm() < 1e-6)
    v = gaussian3(rng, 1.0);
  return v.normalized();
}

}  // namespace

void SessionOptions::check() const {
  const auto require = [](bool ok, const char* field) {
    if (!ok) {
      throw Error("out of range", ErrorContext{.field = std::string("SessionOptions.") + field});
    }
  };
  require(duration > 1.0, "duration");
  require(headset_rate > 0.0, "headset_rate");
  require(global_rate > 0.0 && global_rate <= headset_rate, "global_rate");
  require(global_latency >= 0.0, "global_latency");
  require(global_position_sigma >= 0.0, "global_position_sigma");
  require(global_rotation_sigma >= 0.0, "global_rotation_sigma");
  require(outlier_fraction >= 0.0 && outlier_fraction <= 1.0, "outlier_fraction");
}

SE3 simulated_head_pose(double t) {
  const double a = 8.0, b = 4.0;
  const Eigen::Vector3d position(a * std::sin(kOmega * t), b * std::sin(2.0 * kOmega * t),
                                 1.65 + 0.02 * std::sin(2.0 * std::numbers::pi * 1.8 * t));
  const double vx = a * kOmega * std::cos(kOmega * t);
  const double vy = 2.0 * b * kOmega * std::cos(2.0 * kOmega * t);
  // Walking direction plus looking around (~50 deg/s peaks), nodding and a little roll.
  const double yaw = std::atan2(vy, vx) + 0.6 * std::sin(2.0 * std::numbers::pi * 0.25 * t);
  const double pitch = 0.2 * std::sin(2.0 * std::numbers::pi * 0.13 * t);
  const double roll = 0.05 * std::sin(2.0 * std::numbers::pi * 0.4 * t);
  return SE3(yaw_pitch_roll(yaw, pitch, roll), position);
}

SimulatedSession simulate_session(const SessionOptions& options) {
  options.check();
  std::mt19937 rng(options.seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> normal(0.0, 1.0);
  const HeadsetDriftModel& m = options.drift;

  SimulatedSession s;
  s.initial_world_from_xr =
      SE3(yaw_pitch_roll(2.0 * std::numbers::pi * uniform(rng), 0.0, 0.0),
          Eigen::Vector3d(4.0 * uniform(rng) - 2.0, 4.0 * uniform(rng) - 2.0, 0.0));
  const double bias_heading = 2.0 * std::numbers::pi * uniform(rng);
  const Eigen::Vector3d bias_velocity =
      m.position_bias * Eigen::Vector3d(std::cos(bias_heading), std::sin(bias_heading), 0.0);

  const double dt = 1.0 / options.headset_rate;
  const auto n = static_cast<std::size_t>(options.duration * options.headset_rate);
  SE3 world_from_xr = s.initial_world_from_xr;
  for (std::size_t i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) * dt;
    if (i > 0) {
      const double sq = std::sqrt(dt);
      const Eigen::Vector3d rotation_step(m.tilt_random_walk * sq * normal(rng),
                                          m.tilt_random_walk * sq * normal(rng),
                                          m.yaw_bias * dt + m.yaw_random_walk * sq * normal(rng));
      const Eigen::Vector3d translation_step =
          bias_velocity * dt + gaussian3(rng, m.position_random_walk * sq);
      world_from_xr = SE3(SO3::exp(rotation_step) * world_from_xr.so3(),
                          world_from_xr.translation() + translation_step);
    }
    const SE3 truth = simulated_head_pose(t);
    const SE3 noise(SO3::exp(gaussian3(rng, m.rotation_noise)), gaussian3(rng, m.position_noise));
    s.truth.push_back({t, truth});
    s.headset.push_back({t, world_from_xr.inverse() * truth * noise});
  }

  const double global_dt = 1.0 / options.global_rate;
  for (double t = 0.5 * global_dt; t < options.duration - options.global_latency; t += global_dt) {
    GlobalSample g;
    g.exposure_time = t;
    g.arrival_time = t + options.global_latency;
    const SE3 truth = simulated_head_pose(t);
    g.world_from_head = SE3(SO3::exp(gaussian3(rng, options.global_rotation_sigma)) * truth.so3(),
                            truth.translation() + gaussian3(rng, options.global_position_sigma));
    if (uniform(rng) < options.outlier_fraction) {
      const double scale = 0.5 + uniform(rng);
      g.outlier = true;
      g.world_from_head = SE3(
          SO3::exp(random_unit(rng) * options.outlier_rotation * scale) * g.world_from_head.so3(),
          g.world_from_head.translation() + random_unit(rng) * options.outlier_position * scale);
    }
    s.global.push_back(g);
  }
  return s;
}

Trajectory replay_session(const SimulatedSession& session, const FuserOptions& options) {
  DriftFuser fuser(options);
  return replay_session(session, fuser);
}

Trajectory replay_session(const SimulatedSession& session, DriftFuser& fuser) {
  return replay_headset(session.headset, session.global, fuser);
}

Trajectory raw_headset(const SimulatedSession& session) {
  Trajectory out;
  out.reserve(session.headset.size());
  for (const StampedPose& h : session.headset) {
    out.push_back({h.timestamp, session.initial_world_from_xr * h.world_from_cam});
  }
  return out;
}

FuserOptions snap_options() {
  FuserOptions o;
  o.time_alignment = false;
  o.filter.gating = false;
  o.filter.process_noise = 1e6;  // gain ~ 1: every global pose replaces D
  o.filter.measurement_noise = 1e-6;
  return o;
}

FuserOptions paper_options() {
  FuserOptions o;
  o.time_alignment = false;
  o.filter.gating = false;
  o.max_gap_periods = 1.0;  // the paper's Q is per global pose, whatever the gap
  return o;
}

FuserOptions ours_options() {
  FuserOptions o;
  o.time_alignment = true;
  o.filter.gating = true;
  return o;
}

ErrorMetrics evaluate_trajectory(const Trajectory& estimate, const Trajectory& truth,
                                 double skip_seconds) {
  std::vector<double> position, rotation, jump_position, jump_rotation;
  const std::size_t n = std::min(estimate.size(), truth.size());
  for (std::size_t i = 0; i < n; ++i) {
    if (truth[i].timestamp < truth.front().timestamp + skip_seconds) continue;
    const SE3& e = estimate[i].world_from_cam;
    const SE3& t = truth[i].world_from_cam;
    position.push_back(translation_distance(e, t));
    rotation.push_back(rotation_distance(e, t));
    if (i + 1 < n) {
      const SE3& e1 = estimate[i + 1].world_from_cam;
      const SE3& t1 = truth[i + 1].world_from_cam;
      jump_position.push_back(
          ((e1.translation() - e.translation()) - (t1.translation() - t.translation())).norm());
      const SO3 de = e.so3().inverse() * e1.so3();
      const SO3 dt = t.so3().inverse() * t1.so3();
      jump_rotation.push_back(angular_distance(de, dt));
    }
  }
  ErrorMetrics m;
  if (position.empty()) return m;
  const auto rms = [](const std::vector<double>& v) {
    double sum = 0.0;
    for (double x : v)
      sum += x * x;
    return std::sqrt(sum / static_cast<double>(v.size()));
  };
  m.position_rmse = rms(position);
  m.rotation_rmse = rms(rotation);
  m.position_p95 = quantile(position, 0.95);
  m.rotation_p95 = quantile(rotation, 0.95);
  if (!jump_position.empty()) {
    m.jitter_position_p99 = quantile(jump_position, 0.99);
    m.jitter_rotation_p99 = quantile(jump_rotation, 0.99);
  }
  return m;
}

StaticLogStats analyze_static_drift_log(const std::filesystem::path& path, double rate) {
  check_input_file(path, "drift log");
  std::ifstream in(path);
  if (!in) throw Error("cannot open the drift log", ErrorContext{.file = path.string()});
  std::vector<Eigen::Vector3d> positions;
  std::string line;
  std::int64_t number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    double v[12];
    for (double& x : v) {
      if (!(fields >> x)) {
        throw Error("expected 12 numbers (a 3x4 pose)",
                    ErrorContext{.file = path.string(), .line = number});
      }
    }
    positions.emplace_back(v[3], v[7], v[11]);
  }
  if (positions.size() < 2 * static_cast<std::size_t>(60 * rate)) {
    throw Error("too short: need at least two minutes of poses",
                ErrorContext{.file = path.string()});
  }
  StaticLogStats s;
  s.samples = positions.size();
  s.rate = rate;
  double sum = 0.0;
  for (std::size_t i = 1; i < positions.size(); ++i) {
    sum += (positions[i] - positions[i - 1]).squaredNorm();
  }
  // A step between two independent noisy samples has variance 2 sigma^2 per axis.
  s.position_noise = std::sqrt(sum / static_cast<double>(positions.size() - 1) / 6.0);
  const auto per_minute = static_cast<std::size_t>(60 * rate);
  Eigen::Vector3d first = Eigen::Vector3d::Zero();
  for (std::size_t start = 0; start + per_minute <= positions.size(); start += per_minute) {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (std::size_t i = start; i < start + per_minute; ++i)
      mean += positions[i];
    mean /= static_cast<double>(per_minute);
    if (start == 0) first = mean;
    s.wander = std::max(s.wander, (mean - first).norm());
  }
  s.random_walk = s.wander / std::sqrt(static_cast<double>(positions.size()) / rate);
  return s;
}

}  // namespace coloc::fusion
