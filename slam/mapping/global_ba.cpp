#include "slam/mapping/global_ba.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "slam/core/timing.hpp"
#include "slam/mapping/ba_window.hpp"

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

// The mean gyro bias over the pairs kept in the last pass (camera frame, rad/s).
Eigen::Vector3d mean_gyro_bias(const optim::BundleProblem& problem,
                               const optim::BundleResult& result) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  std::size_t n = 0;
  for (std::size_t i = 0; i < problem.gyro.size(); ++i) {
    if (result.gyro_outlier[i]) continue;
    sum += result.gyro_bias[problem.gyro[i].pose_a];
    ++n;
  }
  return n > 0 ? Eigen::Vector3d(sum / static_cast<double>(n)) : Eigen::Vector3d::Zero();
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
    record_inertial(shared.map, imu);
    w = make_window(m, all);
    add_inertial_terms(m, w.pose_ids, InertialModels::of(imu), w.problem);
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
  if (!result.accel_bias.empty()) report.accel_bias = result.accel_bias.back();
  report.gravity_rms = result.gravity_rms;
  report.gyro_pairs = w.problem.gyro.size();
  report.gyro_outliers = flagged(result.gyro_outlier);
  report.gyro_rms = result.gyro_rms;
  report.gyro_bias = mean_gyro_bias(w.problem, result);
  return report;
}

}  // namespace coloc::slam::mapping
