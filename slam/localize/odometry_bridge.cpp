#include "slam/localize/odometry_bridge.hpp"

#include <algorithm>
#include <utility>

#include "slam/core/error.hpp"
#include "slam/optim/pose_optimizer.hpp"

namespace coloc::slam::localize {

namespace {

// Below this many matches a prediction is not worth a pose optimization: the search is
// widened, then retried without the motion (ORB-SLAM's motion-model thresholds).
constexpr std::size_t kMinMatches = 20;

}  // namespace

void OdometryBridgeOptions::check() const {
  if (max_frames < 0) throw Error("OdometryBridgeOptions.max_frames must be >= 0");
  if (min_inliers < 10) throw Error("OdometryBridgeOptions.min_inliers must be >= 10");
  if (!(reanchor_ratio >= 0.0 && reanchor_ratio <= 1.0))
    throw Error("OdometryBridgeOptions.reanchor_ratio must be in [0, 1]");
  if (!(search_radius_px > 0.0)) throw Error("OdometryBridgeOptions.search_radius_px must be > 0");
  if (max_descriptor_distance < 0 || max_descriptor_distance > 256)
    throw Error("OdometryBridgeOptions.max_descriptor_distance must be in 0..256");
}

OdometryBridge::OdometryBridge(OdometryBridgeOptions options) : options_(options) {
  options_.check();
}

void OdometryBridge::reset() {
  points_.clear();
  anchor_inliers_ = 0;
  has_last_ = has_velocity_ = false;
  bridged_ = 0;
}

void OdometryBridge::anchor(const frame::Frame& frame, const SE3& cam_from_world) {
  bridged_ = 0;
  set_last(cam_from_world);
  set_anchor(frame, cam_from_world);
}

void OdometryBridge::set_last(const SE3& cam_from_world) {
  // The velocity is only meaningful between consecutive poses; a first one (or one after the
  // bridge ended) has none.
  if (has_last_) {
    velocity_ = cam_from_world * last_cam_from_world_.inverse();
    has_velocity_ = true;
  }
  last_cam_from_world_ = cam_from_world;
  has_last_ = true;
}

void OdometryBridge::set_anchor(const frame::Frame& frame, const SE3& cam_from_world) {
  points_.clear();
  anchor_inliers_ = 0;
  const frame::FrameGeometry& g = frame.geometry();
  const SE3 world_from_cam = cam_from_world.inverse();
  for (std::size_t i = 0; i < frame.size(); ++i) {
    // Close points only: a far point's depth error grows with the square of its depth, and
    // every anchor's error stays in the bridged poses that follow (ORB-SLAM2 keeps only close
    // ones as its visual-odometry points too).
    if (!frame.is_close(i)) continue;
    const auto& kp = frame.features.keypoints[i];
    const double z = frame.depth[i];
    const Eigen::Vector3d cam((kp.ux - g.cx) * z / g.fx, (kp.uy - g.cy) * z / g.fy, z);
    points_.push_back({world_from_cam * cam, frame.features.descriptors[i], kp.level});
  }
}

std::vector<std::pair<std::size_t, std::size_t>> OdometryBridge::match(const frame::Frame& frame,
                                                                       const SE3& cam_from_world,
                                                                       double radius_px) const {
  const frame::FrameGeometry& g = frame.geometry();
  std::vector<int> best_distance(frame.size(), options_.max_descriptor_distance + 1);
  std::vector<std::size_t> claimed_by(frame.size(), points_.size());
  for (std::size_t p = 0; p < points_.size(); ++p) {
    const Eigen::Vector3d pc = cam_from_world * points_[p].world;
    if (pc.z() <= 0.0) continue;
    const Eigen::Vector2d uv = g.project(pc);
    if (!g.in_bounds(uv)) continue;
    const int level = points_[p].level;
    const double r = radius_px * g.scale_factors[static_cast<std::size_t>(level)];
    int best = options_.max_descriptor_distance + 1;
    std::size_t best_kp = frame.size();
    for (std::size_t k :
         frame.features_in_area(uv.x(), uv.y(), r, std::max(0, level - 1), level + 1)) {
      const int d =
          features::hamming_distance(points_[p].descriptor, frame.features.descriptors[k]);
      if (d < best) {
        best = d;
        best_kp = k;
      }
    }
    // A keypoint claimed by two points keeps the closer descriptor.
    if (best_kp < frame.size() && best < best_distance[best_kp]) {
      best_distance[best_kp] = best;
      claimed_by[best_kp] = p;
    }
  }
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  for (std::size_t k = 0; k < frame.size(); ++k)
    if (claimed_by[k] < points_.size()) pairs.emplace_back(claimed_by[k], k);
  return pairs;
}

std::optional<OdometryPose> OdometryBridge::track(const frame::Frame& frame) {
  if (points_.empty() || bridged_ >= options_.max_frames) return std::nullopt;
  const frame::FrameGeometry& g = frame.geometry();
  const SE3 predicted = has_velocity_ ? velocity_ * last_cam_from_world_ : last_cam_from_world_;
  auto pairs = match(frame, predicted, options_.search_radius_px);
  if (pairs.size() < kMinMatches) pairs = match(frame, predicted, 2.0 * options_.search_radius_px);
  SE3 start = predicted;
  if (pairs.size() < kMinMatches && has_velocity_) {
    start = last_cam_from_world_;
    pairs = match(frame, start, 2.0 * options_.search_radius_px);
  }
  if (pairs.size() < kMinMatches) {
    reset();
    return std::nullopt;
  }
  std::vector<optim::PoseObservation> observations;
  observations.reserve(pairs.size());
  for (const auto& [p, k] : pairs) {
    optim::PoseObservation o;
    o.world = points_[p].world;
    o.pixel = frame.pixel(k);
    o.u_right = frame.u_right[k];
    o.inv_sigma2 = 1.0 / g.level_sigma2[static_cast<std::size_t>(frame.level(k))];
    observations.push_back(o);
  }
  const optim::PoseOptimizationResult solved =
      optim::optimize_pose(start, observations, {g.fx, g.fy, g.cx, g.cy, g.bf});
  if (solved.inliers < options_.min_inliers) {
    reset();
    return std::nullopt;
  }
  ++bridged_;
  set_last(solved.cam_from_world);
  if (anchor_inliers_ == 0) anchor_inliers_ = solved.inliers;
  if (solved.inliers < options_.reanchor_ratio * anchor_inliers_)
    set_anchor(frame, solved.cam_from_world);
  return OdometryPose{solved.cam_from_world, solved.inliers, bridged_};
}

}  // namespace coloc::slam::localize
