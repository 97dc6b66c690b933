#include "slam/reloc/relocalizer.hpp"

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "slam/core/error.hpp"
#include "slam/tracking/pose_support.hpp"
#include "slam/tracking/search.hpp"

namespace coloc::slam::reloc {

void RelocalizationOptions::check() const {
  if (max_candidates < 1) throw Error("RelocalizationOptions.max_candidates must be >= 1");
  if (min_bow_matches < 4) throw Error("RelocalizationOptions.min_bow_matches must be >= 4");
  if (ransac_iterations < 1) throw Error("RelocalizationOptions.ransac_iterations must be >= 1");
  if (!(ransac_reprojection_px > 0.0))
    throw Error("RelocalizationOptions.ransac_reprojection_px must be > 0");
  if (min_inliers < 10) throw Error("RelocalizationOptions.min_inliers must be >= 10");
}

namespace {

// EPnP + RANSAC on the frame's current matches; sets the pose and keeps only the inliers.
bool solve_pnp(frame::Frame& frame, const map::Map& map, const RelocalizationOptions& options) {
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
  if (object.size() < 6) return false;
  const auto& g = frame.geometry();
  const cv::Matx33d k(g.fx, 0, g.cx, 0, g.fy, g.cy, 0, 0, 1);
  cv::Mat rvec, tvec;
  std::vector<int> inliers;
  const bool ok = cv::solvePnPRansac(
      object, image, k, cv::noArray(), rvec, tvec, false, options.ransac_iterations,
      static_cast<float>(options.ransac_reprojection_px), 0.99, inliers, cv::SOLVEPNP_EPNP);
  if (!ok || static_cast<int>(inliers.size()) < options.min_ransac_inliers) return false;
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
  return true;
}

}  // namespace

RelocalizationResult relocalize(frame::Frame& frame, const map::Map& map,
                                const bow::BowDatabase& database,
                                const RelocalizationOptions& options) {
  options.check();
  RelocalizationResult result;
  bow::QueryOptions query;
  query.max_results = options.max_candidates;
  query.min_common_words_ratio = 0.8;
  const auto candidates = database.query(frame.bow, query);
  result.candidates = static_cast<int>(candidates.size());
  for (const auto& c : candidates) {
    const map::Keyframe* kf = map.keyframe(KeyframeId(c.image));
    if (!kf || kf->frame.feature_vector.entries.empty()) continue;
    frame.points.assign(frame.size(), MapPointId::invalid());
    frame.outlier.assign(frame.size(), 0);
    if (tracking::search_by_bow(*kf, frame, map) < options.min_bow_matches) continue;
    if (!solve_pnp(frame, map, options)) continue;
    int inliers = tracking::optimize_frame_pose(frame, map);
    if (inliers < 10) continue;
    if (inliers < options.min_inliers) {
      tracking::drop_outliers(frame);
      tracking::search_keyframe_points(frame, *kf, map, 10.0, tracking::kDescriptorHigh);
      inliers = tracking::optimize_frame_pose(frame, map);
    }
    if (inliers >= options.min_inliers) {
      tracking::drop_outliers(frame);
      frame.has_pose = true;
      result.success = true;
      result.keyframe = kf->id;
      result.inliers = inliers;
      return result;
    }
  }
  frame.points.assign(frame.size(), MapPointId::invalid());
  frame.outlier.assign(frame.size(), 0);
  return result;
}

}  // namespace coloc::slam::reloc
