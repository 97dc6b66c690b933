#include "slam/mapping/global_ba.hpp"

#include <algorithm>
#include <cmath>
#include <tuple>
#include <utility>

#include "slam/core/timing.hpp"
#include "slam/mapping/ba_window.hpp"
#include "slam/optim/gravity_cost.hpp"
#include "slam/optim/gyro_cost.hpp"

namespace coloc::slam::mapping {

namespace {

double rms_reprojection(const optim::BundleProblem& problem, const optim::Intrinsics& k,
                        const std::vector<std::uint8_t>& skip) {
  double sum = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < problem.observations.size(); ++i) {
    if (skip[i]) continue;
    const auto& o = problem.observations[i];
    const Eigen::Vector3d p = problem.poses[o.pose].cam_from_world * problem.points[o.point];
    if (o.u_right >= 0.0) {
      Eigen::Vector3d r;
      if (!optim::stereo_residual(k, p, {o.pixel.x(), o.pixel.y(), o.u_right}, r, nullptr))
        continue;
      sum += r.squaredNorm();
      ++n;
    } else {
      Eigen::Vector2d r;
      if (!optim::mono_residual(k, p, o.pixel, r, nullptr)) continue;
      sum += r.squaredNorm();
      ++n;
    }
  }
  return n > 0 ? std::sqrt(sum / static_cast<double>(n)) : 0.0;
}

std::size_t flagged(const std::vector<std::uint8_t>& flags) {
  return static_cast<std::size_t>(std::count(flags.begin(), flags.end(), 1));
}

// RMS length of the gravity residuals (m/s^2) kept in the last pass, at the problem's poses.
double rms_gravity(const optim::BundleProblem& problem, const optim::BundleResult& result) {
  double sum = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < problem.gravity.size(); ++i) {
    if (result.gravity_outlier[i]) continue;
    const auto& g = problem.gravity[i];
    const optim::GravityCost cost(g.specific_force_cam, g.accel_world,
                                  problem.gravity_model.magnitude, 1.0);
    double pose[7];
    optim::pose_to_array(problem.poses[g.pose].cam_from_world, pose);
    const double* params[3] = {pose, result.up_world.data(), result.accel_bias.data()};
    Eigen::Vector3d r;
    cost.Evaluate(params, r.data(), nullptr);
    sum += r.squaredNorm();
    ++n;
  }
  return n > 0 ? std::sqrt(sum / static_cast<double>(n)) : 0.0;
}

// RMS angle (rad) of the gyro residuals kept in the last pass, at the problem's poses, and the
// mean bias.
std::pair<double, Eigen::Vector3d> gyro_fit(const optim::BundleProblem& problem,
                                            const optim::BundleResult& result) {
  double sum = 0.0;
  std::size_t n = 0;
  Eigen::Vector3d bias_sum = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < problem.gyro.size(); ++i) {
    if (result.gyro_outlier[i]) continue;
    const auto& g = problem.gyro[i];
    const optim::GyroCost cost(g.cam_a_from_cam_b, g.bias_jacobian, 1.0);
    double a[7], b[7];
    optim::pose_to_array(problem.poses[g.pose_a].cam_from_world, a);
    optim::pose_to_array(problem.poses[g.pose_b].cam_from_world, b);
    const Eigen::Vector3d& bias = result.gyro_bias[g.pose_a];
    const double* params[3] = {a, b, bias.data()};
    Eigen::Vector3d r;
    cost.Evaluate(params, r.data(), nullptr);
    sum += r.squaredNorm();
    bias_sum += bias;
    ++n;
  }
  if (n == 0) return {0.0, Eigen::Vector3d::Zero()};
  const double count = static_cast<double>(n);
  return {std::sqrt(sum / count), bias_sum / count};
}

// Consecutive keyframes in time from `first` on (InertialMeasurements::first_keyframe).
void add_gyro(const map::Map& m, const std::vector<KeyframeId>& pose_ids, KeyframeId first,
              const GyroMeasurements& gyro, optim::BundleProblem& problem) {
  problem.gyro_model = gyro.options().model;
  std::vector<std::pair<double, std::uint32_t>> by_time;
  for (std::size_t i = 0; i < pose_ids.size(); ++i)
    if (pose_ids[i] >= first)
      by_time.emplace_back(m.keyframe(pose_ids[i])->frame.timestamp, static_cast<std::uint32_t>(i));
  std::sort(by_time.begin(), by_time.end());
  for (std::size_t i = 1; i < by_time.size(); ++i) {
    auto g = gyro.between(by_time[i - 1].first, by_time[i].first);
    if (!g) continue;
    g->pose_a = by_time[i - 1].second;
    g->pose_b = by_time[i].second;
    problem.gyro.push_back(*g);
  }
}

}  // namespace

GlobalBaReport global_bundle_adjustment(map::SharedMap& shared, const GlobalBaOptions& options,
                                        const InertialMeasurements& imu) {
  options.check();
  GlobalBaReport report;
  BaWindow w;
  {
    std::lock_guard lock(shared.mutex);
    const map::Map& m = shared.map;
    if (m.keyframe_count() < 2) return report;
    std::vector<KeyframeId> all;
    for (const auto& [id, kf] : m.keyframes())
      all.push_back(id);
    std::sort(all.begin(), all.end());  // deterministic problem order
    w = make_window(m, all);
    if (imu.gyro) add_gyro(m, w.pose_ids, imu.first_keyframe, *imu.gyro, w.problem);
    if (imu.gravity) {
      w.problem.gravity_model = imu.gravity->options().model;
      for (std::size_t i = 0; i < w.pose_ids.size(); ++i) {
        if (w.pose_ids[i] < imu.first_keyframe) continue;
        auto g = imu.gravity->at(m.keyframe(w.pose_ids[i])->frame.timestamp);
        if (!g) continue;
        g->pose = static_cast<std::uint32_t>(i);
        w.problem.gravity.push_back(*g);
      }
    }
  }
  const optim::BundleProblem initial = w.problem;
  Stopwatch watch;
  const optim::BundleResult result = optim::bundle_adjust(w.problem, w.intrinsics, options.ba);
  report.ms = watch.elapsed_ms();
  report.initial_rms_px = rms_reprojection(initial, w.intrinsics, result.outlier);
  report.final_rms_px = rms_reprojection(w.problem, w.intrinsics, result.outlier);
  {
    std::lock_guard lock(shared.mutex);
    apply_window(shared.map, w, result);
  }
  report.keyframes = w.pose_ids.size();
  report.points = w.point_ids.size();
  report.observations = w.problem.observations.size();
  report.outliers = flagged(result.outlier);
  report.iterations = result.iterations;
  report.gravity_keyframes = w.problem.gravity.size();
  report.gravity_outliers = flagged(result.gravity_outlier);
  report.accel_bias = result.accel_bias;
  report.gravity_rms = rms_gravity(w.problem, result);
  report.gyro_pairs = w.problem.gyro.size();
  report.gyro_outliers = flagged(result.gyro_outlier);
  std::tie(report.gyro_rms, report.gyro_bias) = gyro_fit(w.problem, result);
  return report;
}

}  // namespace coloc::slam::mapping
