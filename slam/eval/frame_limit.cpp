#include "slam/eval/frame_limit.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <variant>

#include "slam/core/error.hpp"
#include "slam/features/descriptor.hpp"
#include "slam/features/orb_extractor.hpp"
#include "slam/frame/frame.hpp"
#include "slam/matching/search.hpp"
#include "slam/optim/pose_optimizer.hpp"

namespace coloc::eval {
namespace {

using slam::frame::Frame;
using slam::frame::FrameGeometry;
using slam::optim::PoseObservation;

// Half the interval of the central difference that gives the true rotation rate (seconds).
constexpr double kRateHalfInterval = 0.01;

// world_from_cam at time t, linearly interpolated (SE3 geodesic) between ground-truth samples;
// none outside the ground truth or across a gap.
std::optional<SE3> pose_at(const Trajectory& gt, double t, double max_gap) {
  auto it = std::lower_bound(gt.begin(), gt.end(), t,
                             [](const StampedPose& p, double x) { return p.timestamp < x; });
  if (it == gt.end() || it == gt.begin()) return std::nullopt;
  const StampedPose& b = *it;
  const StampedPose& a = *(it - 1);
  if (b.timestamp - a.timestamp > max_gap) return std::nullopt;
  return interpolate(a.world_from_cam, b.world_from_cam,
                     (t - a.timestamp) / (b.timestamp - a.timestamp));
}

// Nearest-descriptor matching (not mutual) of prev's keypoints with depth into cur: same or
// neighbouring level, within the window, Hamming <= TH_LOW and the ratio test.
std::vector<PoseObservation> observations(const Frame& prev, const Frame& cur,
                                          const FrameLimitOptions& options) {
  std::vector<PoseObservation> obs;
  const FrameGeometry& g = cur.geometry();
  for (std::size_t i = 0; i < prev.size(); ++i) {
    if (!prev.has_depth(i)) continue;
    const auto& kp = prev.features.keypoints[i];
    slam::features::NearestTwo nearest;
    for (std::size_t j : cur.features_in_area(kp.ux, kp.uy, options.window_px,
                                              std::max(0, kp.level - 1), kp.level + 1)) {
      nearest.offer(slam::features::hamming_distance(prev.features.descriptors[i],
                                                     cur.features.descriptors[j]),
                    j);
    }
    if (nearest.best > slam::matching::kDescriptorLow ||
        nearest.best > options.max_ratio * nearest.second)
      continue;
    const std::size_t j = nearest.index;
    PoseObservation o;
    o.world = prev.unproject_world(i);
    o.pixel = cur.pixel(j);
    o.u_right = cur.u_right[j];
    o.inv_sigma2 = 1.0 / g.level_sigma2[static_cast<std::size_t>(cur.level(j))];
    obs.push_back(o);
  }
  return obs;
}

// The run's geometry from the settings, sized by the first image (settings may omit the size).
std::shared_ptr<const FrameGeometry> make_geometry(const settings::Settings& settings,
                                                   const cv::Mat& image,
                                                   const slam::features::OrbExtractor& extractor,
                                                   double readout) {
  Camera camera = settings.camera;
  std::visit(
      [&](auto& c) {
        c.width = image.cols;
        c.height = image.rows;
      },
      camera);
  auto geometry = std::make_shared<FrameGeometry>(FrameGeometry::make(
      camera, settings.depth->bf, settings.depth->close_depth, extractor.scale_factors()));
  geometry->readout = readout;
  return geometry;
}

// Moves cur's keypoints to the middle row's time with the ground truth's rotation rate at the
// frame's time (camera frame, central difference).
void compensate_with_truth(Frame& cur, const Trajectory& gt, int rows,
                           const FrameLimitOptions& options) {
  const auto before = pose_at(gt, cur.timestamp - kRateHalfInterval, options.max_ground_truth_gap);
  const auto after = pose_at(gt, cur.timestamp + kRateHalfInterval, options.max_ground_truth_gap);
  if (!before || !after) return;
  const Eigen::Vector3d omega =
      (before->so3().inverse() * after->so3()).log() / (2.0 * kRateHalfInterval);
  cur.compensate_rolling_shutter(omega, rows, cur.geometry().readout);
}

// Solves cur's pose from prev (at its truth); none when too few matches.
std::optional<FramePairError> solve_pair(const Frame& prev, const Frame& cur,
                                         const SE3& world_from_cam,
                                         const FrameLimitOptions& options) {
  const std::vector<PoseObservation> obs = observations(prev, cur, options);
  if (obs.size() < options.min_matches) return std::nullopt;
  const FrameGeometry& g = cur.geometry();
  const slam::optim::Intrinsics intrinsics{g.fx, g.fy, g.cx, g.cy, g.bf};
  const auto r = slam::optim::optimize_pose(cur.cam_from_world, obs, intrinsics);
  const SE3 error = r.cam_from_world * world_from_cam;  // identity when exact
  FramePairError e;
  e.timestamp = cur.timestamp;
  e.rotation_deg = error.so3().log().norm() * 180.0 / std::numbers::pi;
  e.translation_mm = 1e3 * error.inverse().translation().norm();
  e.matches = obs.size();
  e.inliers = r.inliers;
  return e;
}

void summarize_pairs(FrameLimitResult& result) {
  std::vector<double> rotation, translation, inliers;
  for (const FramePairError& p : result.pairs) {
    rotation.push_back(p.rotation_deg);
    translation.push_back(p.translation_mm);
    inliers.push_back(static_cast<double>(p.inliers));
  }
  result.rotation_deg = compute_stats(rotation);
  result.translation_mm = compute_stats(translation);
  result.inliers = summarize(inliers);
}

}  // namespace

void FrameLimitOptions::check() const {
  if (!(window_px > 0.0)) throw Error("must be positive", {.field = "window_px"});
  if (readout && !(*readout >= 0.0 && *readout <= 0.5))
    throw Error("must be within [0, 0.5] seconds", {.field = "readout"});
  if (!(max_ratio > 0.0 && max_ratio <= 1.0))
    throw Error("must be within (0, 1]", {.field = "max_ratio"});
  if (min_matches < 3) throw Error("must be at least 3", {.field = "min_matches"});
  if (!(max_ground_truth_gap > 0.0))
    throw Error("must be positive", {.field = "max_ground_truth_gap"});
}

std::vector<FramePairError> FrameLimitResult::worst(std::size_t n) const {
  std::vector<FramePairError> sorted = pairs;
  std::stable_sort(sorted.begin(), sorted.end(), [](const auto& a, const auto& b) {
    return a.translation_mm > b.translation_mm;
  });
  sorted.resize(std::min(n, sorted.size()));
  return sorted;
}

FrameLimitResult measure_frame_limit(const dataset::Sequence& sequence,
                                     const settings::Settings& settings,
                                     const FrameLimitOptions& options,
                                     const FrameLimitProgress& progress) {
  options.check();
  const Trajectory& gt = sequence.ground_truth();
  if (gt.empty()) throw Error("sequence has no ground truth", {.file = sequence.folder().string()});
  if (!settings.depth)
    throw Error("settings without depth (Camera.bf)", {.file = settings.source.string()});
  FrameLimitResult result;
  result.readout = options.readout.value_or(settings.readout_time.value_or(0.0));
  const auto& orb = settings.orb;
  slam::features::OrbExtractor extractor(slam::features::ExtractorOptions{
      orb.n_features, orb.scale_factor, orb.n_levels, orb.ini_th_fast, orb.min_th_fast});
  std::shared_ptr<const FrameGeometry> geometry;
  std::optional<Frame> prev;
  for (std::size_t k = 0; k < sequence.size(); ++k) {
    const dataset::Frame f = sequence.frame(k);
    if (progress) progress(k + 1, sequence.size());
    const auto world_from_cam = pose_at(gt, f.timestamp, options.max_ground_truth_gap);
    if (!world_from_cam) {
      prev.reset();  // the chain of truth is broken: the next frame has nothing to start from
      continue;
    }
    if (!geometry) geometry = make_geometry(settings, f.color, extractor, result.readout);
    cv::Mat grey = f.color;
    if (grey.channels() == 3) cv::cvtColor(f.color, grey, cv::COLOR_BGR2GRAY);
    Frame cur(FrameId(k + 1), f.timestamp, extractor.extract(grey, &settings.camera), f.depth,
              geometry);
    cur.cam_from_world = world_from_cam->inverse();
    cur.has_pose = true;
    if (result.readout > 0.0) compensate_with_truth(cur, gt, f.color.rows, options);
    if (prev) {
      if (auto pair = solve_pair(*prev, cur, *world_from_cam, options)) {
        pair->frame = k;
        result.pairs.push_back(*pair);
      }
    }
    prev = std::move(cur);
  }
  if (result.pairs.empty())
    throw Error("no frame pair with ground truth and depth", {.file = sequence.folder().string()});
  summarize_pairs(result);
  return result;
}

}  // namespace coloc::eval
