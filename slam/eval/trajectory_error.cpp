#include "slam/eval/trajectory_error.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "slam/core/align.hpp"
#include "slam/core/error.hpp"
#include "slam/core/timing.hpp"

namespace coloc::eval {
namespace {

struct Associated {
  Trajectory gt;
  Trajectory est;
};

Associated associate(const Trajectory& ground_truth, const Trajectory& estimate, double max_dt) {
  Associated a;
  for (const auto& [i, j] : associate_by_time(ground_truth, estimate, max_dt)) {
    a.gt.push_back(ground_truth[i]);
    a.est.push_back(estimate[j]);
  }
  return a;
}

Sim3 align(const Associated& a, Alignment alignment) {
  if (alignment == Alignment::kNone) return {};
  std::vector<Eigen::Vector3d> src;
  std::vector<Eigen::Vector3d> dst;
  for (std::size_t k = 0; k < a.gt.size(); ++k) {
    src.push_back(a.est[k].world_from_cam.translation());
    dst.push_back(a.gt[k].world_from_cam.translation());
  }
  const AlignmentResult r =
      align_points(src, dst, {.estimate_scale = alignment == Alignment::kSim3});
  if (!r.usable) {
    throw Error(
        "cannot align the trajectories: the estimated positions are (nearly) collinear "
        "or too few; use --align none");
  }
  return r.dst_from_src;
}

SE3 transform(const Sim3& s, const SE3& pose) {
  return {s.so3() * pose.so3(), s * pose.translation()};
}

}  // namespace

Alignment parse_alignment(const std::string& name) {
  if (name == "none") return Alignment::kNone;
  if (name == "se3") return Alignment::kSE3;
  if (name == "sim3") return Alignment::kSim3;
  throw Error("unknown alignment '" + name + "' (expected none, se3 or sim3)");
}

ErrorStats compute_stats(const std::vector<double>& errors) {
  ErrorStats s;
  const SampleStats base = summarize(errors);
  s.count = base.count;
  if (s.count == 0) return s;
  s.mean = base.mean;
  s.median = base.median;
  s.std = base.stddev;
  s.min = base.min;
  s.max = base.max;
  const double sq = std::inner_product(errors.begin(), errors.end(), errors.begin(), 0.0);
  s.rmse = std::sqrt(sq / static_cast<double>(s.count));
  return s;
}

namespace {

// Says what is wrong before association would blame the timestamps.
void check_inputs(const Trajectory& ground_truth, const Trajectory& estimate, double max_dt) {
  if (!(max_dt >= 0.0 && std::isfinite(max_dt))) {
    throw Error("must be a non-negative number of seconds", {.field = "max_dt"});
  }
  if (ground_truth.empty()) throw Error("the ground truth trajectory is empty (no poses)");
  if (estimate.empty()) throw Error("the estimated trajectory is empty (no poses)");
}

}  // namespace

AteResult compute_ate(const Trajectory& ground_truth, const Trajectory& estimate,
                      const AteOptions& options) {
  check_inputs(ground_truth, estimate, options.max_dt);
  const Associated a = associate(ground_truth, estimate, options.max_dt);
  if (a.gt.size() < 3) {
    throw Error("only " + std::to_string(a.gt.size()) + " poses associate within " +
                std::to_string(options.max_dt) +
                " s; check the timestamps (seconds) of both files");
  }
  AteResult r;
  r.gt_from_est = align(a, options.alignment);
  for (std::size_t k = 0; k < a.gt.size(); ++k) {
    const SE3 aligned = transform(r.gt_from_est, a.est[k].world_from_cam);
    r.timestamps.push_back(a.gt[k].timestamp);
    r.errors.push_back((aligned.translation() - a.gt[k].world_from_cam.translation()).norm());
    r.ground_truth.push_back(a.gt[k]);
    r.estimate_aligned.push_back({a.est[k].timestamp, aligned});
  }
  r.translation = compute_stats(r.errors);
  return r;
}

RpeResult compute_rpe(const Trajectory& ground_truth, const Trajectory& estimate,
                      const RpeOptions& options) {
  check_inputs(ground_truth, estimate, options.max_dt);
  if (options.delta == 0) throw Error("RPE delta must be at least 1", {.field = "delta"});
  const Associated a = associate(ground_truth, estimate, options.max_dt);
  if (a.gt.size() <= options.delta) {
    throw Error("only " + std::to_string(a.gt.size()) + " poses associate; RPE with delta " +
                std::to_string(options.delta) + " needs more");
  }
  const Sim3 s = align(a, options.alignment);
  RpeResult r;
  for (std::size_t i = 0; i + options.delta < a.gt.size(); ++i) {
    const std::size_t j = i + options.delta;
    const SE3 gt_rel = a.gt[i].world_from_cam.inverse() * a.gt[j].world_from_cam;
    const SE3 est_rel =
        transform(s, a.est[i].world_from_cam).inverse() * transform(s, a.est[j].world_from_cam);
    const SE3 e = gt_rel.inverse() * est_rel;
    r.timestamps.push_back(a.gt[i].timestamp);
    r.translation_errors.push_back(e.translation().norm());
    r.rotation_errors.push_back(e.so3().angle() * 180.0 / M_PI);
  }
  r.translation = compute_stats(r.translation_errors);
  r.rotation = compute_stats(r.rotation_errors);
  return r;
}

std::optional<SE3> nearest_pose(const Trajectory& trajectory, double timestamp, double max_dt) {
  const StampedPose* best = nullptr;
  for (const StampedPose& p : trajectory)
    if (!best || std::abs(p.timestamp - timestamp) < std::abs(best->timestamp - timestamp))
      best = &p;
  if (!best || std::abs(best->timestamp - timestamp) > max_dt) return std::nullopt;
  return best->world_from_cam;
}

std::optional<PoseError> relative_pose_error(const Trajectory& ground_truth, double time_a,
                                             double time_b, const SE3& b_from_a, double max_dt) {
  const auto world_from_a = nearest_pose(ground_truth, time_a, max_dt);
  const auto world_from_b = nearest_pose(ground_truth, time_b, max_dt);
  if (!world_from_a || !world_from_b) return std::nullopt;
  const SE3 error = (world_from_b->inverse() * *world_from_a).inverse() * b_from_a;
  return PoseError{error.translation().norm(), error.so3().log().norm() * 180.0 / M_PI};
}

}  // namespace coloc::eval
