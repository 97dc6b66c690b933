#include "slam/reloc/relocalizer.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <optional>

#include "slam/core/error.hpp"
#include "slam/matching/pose_support.hpp"
#include "slam/matching/search.hpp"

namespace coloc::slam::reloc {

void RelocalizationOptions::check() const {
  if (max_candidates < 1) throw Error("RelocalizationOptions.max_candidates must be >= 1");
  if (min_bow_matches < 4) throw Error("RelocalizationOptions.min_bow_matches must be >= 4");
  if (ransac_iterations < 1) throw Error("RelocalizationOptions.ransac_iterations must be >= 1");
  if (!(ransac_reprojection_px > 0.0))
    throw Error("RelocalizationOptions.ransac_reprojection_px must be > 0");
  if (min_ransac_inliers < 4) throw Error("RelocalizationOptions.min_ransac_inliers must be >= 4");
  if (min_optimized_inliers < 3)
    throw Error("RelocalizationOptions.min_optimized_inliers must be >= 3");
  if (min_inliers < 10) throw Error("RelocalizationOptions.min_inliers must be >= 10");
  if (!(wide_radius_px > 0.0)) throw Error("RelocalizationOptions.wide_radius_px must be > 0");
  if (wide_max_distance < 0 || wide_max_distance > 256)
    throw Error("RelocalizationOptions.wide_max_distance must be in [0, 256]");
  if (narrow_min_inliers < 0 || narrow_min_inliers >= min_inliers)
    throw Error("RelocalizationOptions.narrow_min_inliers must be in [0, min_inliers)");
  if (!(narrow_radius_px > 0.0)) throw Error("RelocalizationOptions.narrow_radius_px must be > 0");
  if (narrow_max_distance < 0 || narrow_max_distance > 256)
    throw Error("RelocalizationOptions.narrow_max_distance must be in [0, 256]");
}

namespace {

// EPnP + RANSAC on the frame's current matches; sets the pose and keeps only the inliers.
// Returns the number of RANSAC inliers (0 when EPnP failed).
int solve_pnp(frame::Frame& frame, const map::Map& map, const RelocalizationOptions& options) {
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  std::vector<std::size_t> index;
  for (std::size_t i = 0; i < frame.size(); ++i) {
    const map::MapPoint* p = frame.points[i].valid() ? map.point(frame.points[i]) : nullptr;
    if (!p) continue;
    object.emplace_back(p->position.x(), p->position.y(), p->position.z());
    const Eigen::Vector2d uv = frame.pixel(i);
    image.emplace_back(uv.x(), uv.y());
    index.push_back(i);
  }
  if (object.size() < 6) return 0;
  const auto& g = frame.geometry();
  const cv::Matx33d k(g.fx, 0, g.cx, 0, g.fy, g.cy, 0, 0, 1);
  cv::Mat rvec, tvec;
  std::vector<int> inliers;
  const bool ok = cv::solvePnPRansac(
      object, image, k, cv::noArray(), rvec, tvec, false, options.ransac_iterations,
      static_cast<float>(options.ransac_reprojection_px), 0.99, inliers, cv::SOLVEPNP_EPNP);
  if (!ok) return 0;
  if (static_cast<int>(inliers.size()) < options.min_ransac_inliers)
    return static_cast<int>(inliers.size());
  cv::Mat r;
  cv::Rodrigues(rvec, r);
  Eigen::Matrix3d rot;
  Eigen::Vector3d t;
  cv::cv2eigen(r, rot);
  cv::cv2eigen(tvec, t);
  frame.cam_from_world = SE3(SO3::from_matrix(rot), t);
  std::vector<std::uint8_t> keep(frame.size(), 0);
  for (int i : inliers)
    keep[index[static_cast<std::size_t>(i)]] = 1;
  for (std::size_t i = 0; i < frame.size(); ++i) {
    if (!keep[i]) frame.points[i] = MapPointId::invalid();
  }
  return static_cast<int>(inliers.size());
}

}  // namespace

int search_by_projection_passes(frame::Frame& frame, const map::Keyframe& keyframe,
                                const map::Map& map, const RelocalizationOptions& options,
                                RelocalizationResult& result) {
  matching::drop_outliers(frame);
  result.wide_pass_matches = matching::search_keyframe_points(
      frame, keyframe, map, options.wide_radius_px, options.wide_max_distance);
  int inliers = matching::optimize_frame_pose(frame, map);
  result.wide_pass_inliers = inliers;
  if (inliers > options.narrow_min_inliers && inliers < options.min_inliers) {
    // The wide pass's outliers stay matched (ORB-SLAM keeps them in its "found" set), so the
    // narrow pass neither searches their points again nor reuses their keypoints; the final
    // optimization reclassifies them.
    result.narrow_pass_matches = matching::search_keyframe_points(
        frame, keyframe, map, options.narrow_radius_px, options.narrow_max_distance);
    inliers = matching::optimize_frame_pose(frame, map);
    result.narrow_pass_inliers = inliers;
  }
  result.inliers = inliers;
  return inliers;
}

namespace {

// BoW matching, EPnP-RANSAC, optimization and the projection passes against one candidate.
// Fills the stage counters of `result`; true when the frame has >= min_inliers inliers.
bool try_candidate(frame::Frame& frame, const map::Keyframe& kf, const map::Map& map,
                   const RelocalizationOptions& options, RelocalizationResult& result) {
  frame.points.assign(frame.size(), MapPointId::invalid());
  frame.outlier.assign(frame.size(), 0);
  result.bow_matches = matching::search_by_bow(kf, frame, map);
  if (result.bow_matches < options.min_bow_matches) return false;
  result.pnp_inliers = solve_pnp(frame, map, options);
  if (result.pnp_inliers < options.min_ransac_inliers) return false;
  int inliers = matching::optimize_frame_pose(frame, map);
  result.optimized_inliers = inliers;
  result.inliers = inliers;
  if (inliers < options.min_optimized_inliers) return false;
  if (inliers < options.min_inliers)
    inliers = search_by_projection_passes(frame, kf, map, options, result);
  return inliers >= options.min_inliers;
}

}  // namespace

RelocalizationResult relocalize(frame::Frame& frame, const map::Map& map,
                                const bow::BowDatabase& database,
                                const RelocalizationOptions& options,
                                const RelocalizationPrior& prior) {
  options.check();
  bow::QueryOptions query;
  query.max_results = options.max_candidates;
  query.min_common_words_ratio = 0.8;
  std::vector<KeyframeId> order = prior.keyframes;
  for (const auto& c : database.query(frame.bow, query)) {
    const KeyframeId k(c.image);
    if (std::find(order.begin(), order.end(), k) == order.end()) order.push_back(k);
  }
  RelocalizationResult result;
  result.candidates = static_cast<int>(order.size());
  // Without a prior the first candidate that solves the frame wins (ORB-SLAM's rule). With one,
  // every candidate is tried and the solution nearest the last tracked place wins: a look-alike
  // place can be inside the bound too, and the right place is the nearer of the two.
  const bool bounded = std::isfinite(prior.max_distance_m);
  std::optional<RelocalizationResult> best;
  double best_distance = std::numeric_limits<double>::infinity();
  SE3 best_pose;
  std::vector<MapPointId> best_points;
  std::vector<std::uint8_t> best_outlier;
  for (KeyframeId k : order) {
    const map::Keyframe* kf = map.keyframe(k);
    if (!kf || kf->frame.feature_vector.entries.empty()) continue;
    RelocalizationResult attempt = result;
    if (!try_candidate(frame, *kf, map, options, attempt)) continue;
    const double distance =
        (frame.cam_from_world.inverse().translation() - prior.world_centre).norm();
    if (distance > prior.max_distance_m) {
      ++result.implausible;
      result.nearest_implausible_m = std::min(result.nearest_implausible_m, distance);
      continue;
    }
    attempt.keyframe = kf->id;
    if (distance < best_distance) {
      best = attempt;
      best_distance = distance;
      best_pose = frame.cam_from_world;
      best_points = frame.points;
      best_outlier = frame.outlier;
    }
    if (!bounded) break;
  }
  if (!best) {
    frame.points.assign(frame.size(), MapPointId::invalid());
    frame.outlier.assign(frame.size(), 0);
    return result;
  }
  frame.cam_from_world = best_pose;
  frame.points = std::move(best_points);
  frame.outlier = std::move(best_outlier);
  matching::drop_outliers(frame);
  frame.has_pose = true;
  best->success = true;
  best->implausible = result.implausible;
  best->nearest_implausible_m = result.nearest_implausible_m;
  return *best;
}

}  // namespace coloc::slam::reloc
