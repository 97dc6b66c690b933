#include "registration/align/scan_match.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <tuple>

#include "slam/core/error.hpp"

namespace coloc::registration::align {

namespace features = slam::features;

namespace {

// The scan point seen at a sub-pixel position of the rendering. A splat is a flat square at its
// point's depth and the nearest splat wins, so the splat centres behind the pixels are a few
// millimetres off the pixel's ray (towards the camera on slanted surfaces). The splat centres of
// the 5x5 pixels around the position do lie on the surface: a plane fitted to them, intersected
// with the position's ray, gives the surface point the pixel sees. nullopt when the patch is
// mostly empty or straddles a depth edge (relative spread above max_step).
std::optional<Eigen::Vector3d> point_at(const render::RenderResult& r, const PinholeCamera& c,
                                        const SE3& world_from_cam, double x, double y,
                                        double max_step) {
  const int xc = static_cast<int>(std::lround(x));
  const int yc = static_cast<int>(std::lround(y));
  constexpr int kHalf = 2;
  if (xc - kHalf < 0 || yc - kHalf < 0 || xc + kHalf >= r.depth.cols || yc + kHalf >= r.depth.rows)
    return std::nullopt;
  std::vector<Eigen::Vector3d> pts;
  float lo = 1e30f, hi = 0.0f;
  for (int v = yc - kHalf; v <= yc + kHalf; ++v) {
    for (int u = xc - kHalf; u <= xc + kHalf; ++u) {
      const float d = r.depth.at<float>(v, u);
      if (!(d > 0.0f)) continue;
      lo = std::min(lo, d);
      hi = std::max(hi, d);
      const cv::Vec3f& q = r.points.at<cv::Vec3f>(v, u);
      pts.emplace_back(q[0], q[1], q[2]);
    }
  }
  if (pts.size() < 12 || hi > lo * (1.0 + max_step)) return std::nullopt;
  // Distinct splats only (a near splat covers several pixels).
  std::sort(pts.begin(), pts.end(), [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    return std::tie(a.x(), a.y(), a.z()) < std::tie(b.x(), b.y(), b.z());
  });
  pts.erase(std::unique(pts.begin(), pts.end()), pts.end());
  if (pts.size() < 3) return std::nullopt;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : pts)
    mean += p;
  mean /= static_cast<double>(pts.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : pts)
    cov += (p - mean) * (p - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  // A degenerate patch (collinear splats) has no plane: fall back to the mean.
  if (eig.eigenvalues()(1) < 1e-3 * eig.eigenvalues()(2)) return mean;
  const Eigen::Vector3d normal = eig.eigenvectors().col(0);
  const Eigen::Vector3d& origin = world_from_cam.translation();
  const Eigen::Vector3d ray =
      world_from_cam.so3() * Eigen::Vector3d((x - c.cx) / c.fx, (y - c.cy) / c.fy, 1.0);
  const double denom = normal.dot(ray);
  if (std::abs(denom) < 1e-6 * ray.norm()) return std::nullopt;  // grazing
  const double t = normal.dot(mean - origin) / denom;
  if (t <= 0.0) return std::nullopt;
  return origin + t * ray;
}

SE3 pose_of(const cv::Mat& rvec, const cv::Mat& tvec) {
  cv::Mat r;
  cv::Rodrigues(rvec, r);
  Eigen::Matrix3d rot;
  Eigen::Vector3d t;
  cv::cv2eigen(r, rot);
  cv::cv2eigen(tvec, t);
  return SE3(SO3::from_matrix(rot), t);
}

double reprojection_px(const PinholeCamera& c, const SE3& cam_from_world,
                       const ScanCorrespondence& m) {
  const Eigen::Vector3d p = cam_from_world * m.world;
  if (p.z() <= 1e-6) return 1e9;
  return (c.project(p) - m.image_px).norm();
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// Guided matching: nearest descriptor within the radius, ratio test, then one image feature
// per rendered feature (the closest); each match with the scan point behind its rendered feature.
std::vector<ScanCorrespondence> guided_matches(const features::OrbFeatures& image,
                                               const features::OrbFeatures& rf,
                                               const render::RenderResult& rendering,
                                               const SE3& rendering_pose,
                                               const PinholeCamera& camera,
                                               const ScanMatchOptions& o) {
  std::vector<ScanCorrespondence> out;
  const double r2 = o.search_radius_px * o.search_radius_px;
  std::vector<int> best_image(rf.size(), -1), best_distance(rf.size(), 257);
  for (std::size_t i = 0; i < image.size(); ++i) {
    const features::Keypoint& a = image.keypoints[i];
    features::NearestTwo nt;
    for (std::size_t j = 0; j < rf.size(); ++j) {
      const features::Keypoint& b = rf.keypoints[j];
      const double dx = b.ux - a.ux, dy = b.uy - a.uy;
      if (dx * dx + dy * dy > r2 || std::abs(a.level - b.level) > o.max_level_difference) continue;
      nt.offer(features::hamming_distance(image.descriptors[i], rf.descriptors[j]), j);
    }
    if (nt.best > o.max_hamming || nt.best >= o.ratio * nt.second) continue;
    if (nt.best < best_distance[nt.index]) {
      best_distance[nt.index] = nt.best;
      best_image[nt.index] = static_cast<int>(i);
    }
  }
  for (std::size_t j = 0; j < rf.size(); ++j) {
    if (best_image[j] < 0) continue;
    const features::Keypoint& b = rf.keypoints[j];
    const auto p =
        point_at(rendering, camera, rendering_pose.inverse(), b.ux, b.uy, o.max_depth_step);
    if (!p) continue;
    const features::Keypoint& a = image.keypoints[static_cast<std::size_t>(best_image[j])];
    out.push_back(
        {Eigen::Vector2d(a.ux, a.uy), Eigen::Vector2d(b.ux, b.uy), *p, best_distance[j], false});
  }
  return out;
}

// EPnP + RANSAC on the matches, then LM on the inliers and the inlier set of the refined pose,
// twice. Sets out.has_pose, cam_from_world and the inlier flags; false when RANSAC failed.
bool solve_pose(ScanMatch& out, const PinholeCamera& camera, const ScanMatchOptions& o) {
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> pixels;
  for (const ScanCorrespondence& m : out.matches) {
    object.emplace_back(m.world.x(), m.world.y(), m.world.z());
    pixels.emplace_back(m.image_px.x(), m.image_px.y());
  }
  const cv::Matx33d k(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  cv::Mat rvec, tvec;
  std::vector<int> ransac_inliers;
  const bool ok =
      cv::solvePnPRansac(object, pixels, k, cv::noArray(), rvec, tvec, false, o.ransac_iterations,
                         static_cast<float>(o.ransac_reprojection_px), o.ransac_confidence,
                         ransac_inliers, cv::SOLVEPNP_EPNP);
  if (!ok || ransac_inliers.size() < 4) return false;
  std::vector<int> use = ransac_inliers;
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<cv::Point3d> obj;
    std::vector<cv::Point2d> pix;
    for (int i : use) {
      obj.push_back(object[static_cast<std::size_t>(i)]);
      pix.push_back(pixels[static_cast<std::size_t>(i)]);
    }
    if (obj.size() < 4) break;
    cv::solvePnPRefineLM(obj, pix, k, cv::noArray(), rvec, tvec);
    const SE3 pose = pose_of(rvec, tvec);
    use.clear();
    for (std::size_t i = 0; i < out.matches.size(); ++i) {
      if (reprojection_px(camera, pose, out.matches[i]) < o.inlier_px)
        use.push_back(static_cast<int>(i));
    }
  }
  out.has_pose = true;
  out.cam_from_world = pose_of(rvec, tvec);
  std::vector<double> offsets;
  double sq = 0.0;
  for (int i : use) {
    ScanCorrespondence& m = out.matches[static_cast<std::size_t>(i)];
    m.inlier = true;
    offsets.push_back((m.image_px - m.render_px).norm());
    const double e = reprojection_px(camera, out.cam_from_world, m);
    sq += e * e;
  }
  out.inliers = use.size();
  out.median_offset_px = median(offsets);
  out.rms_reprojection_px = use.empty() ? 0.0 : std::sqrt(sq / static_cast<double>(use.size()));
  return true;
}

void classify(ScanMatch& out, const ScanMatchOptions& o) {
  if (out.inliers < static_cast<std::size_t>(o.min_inliers)) {
    out.outcome = MatchOutcome::kTooFewInliers;
  } else if (static_cast<double>(out.inliers) <
             o.min_inlier_ratio * static_cast<double>(out.matches.size())) {
    out.outcome = MatchOutcome::kLowInlierRatio;
  } else {
    out.outcome = MatchOutcome::kOk;
  }
}

}  // namespace

void ScanMatchOptions::check() const {
  orb.check();
  if (!(search_radius_px > 0.0))
    throw Error("must be positive (pixels)", {.field = "search_radius_px"});
  if (max_level_difference < 0) throw Error("must be >= 0", {.field = "max_level_difference"});
  if (max_hamming < 0 || max_hamming > 256)
    throw Error("must be in [0, 256]", {.field = "max_hamming"});
  if (!(ratio > 0.0 && ratio <= 1.0)) throw Error("must be in (0, 1]", {.field = "ratio"});
  if (!(max_depth_step > 0.0)) throw Error("must be positive", {.field = "max_depth_step"});
  if (!(ransac_reprojection_px > 0.0))
    throw Error("must be positive (pixels)", {.field = "ransac_reprojection_px"});
  if (ransac_iterations < 1) throw Error("must be >= 1", {.field = "ransac_iterations"});
  if (!(ransac_confidence > 0.0 && ransac_confidence < 1.0))
    throw Error("must be in (0, 1)", {.field = "ransac_confidence"});
  if (!(inlier_px > 0.0)) throw Error("must be positive (pixels)", {.field = "inlier_px"});
  if (min_inliers < 6)
    throw Error("must be >= 6 (EPnP needs 4, RANSAC more)", {.field = "min_inliers"});
  if (!(min_inlier_ratio >= 0.0 && min_inlier_ratio <= 1.0))
    throw Error("must be in [0, 1]", {.field = "min_inlier_ratio"});
}

const char* outcome_name(MatchOutcome o) {
  switch (o) {
    case MatchOutcome::kOk:
      return "ok";
    case MatchOutcome::kTooFewRenderedFeatures:
      return "too_few_rendered_features";
    case MatchOutcome::kTooFewMatches:
      return "too_few_matches";
    case MatchOutcome::kPnpFailed:
      return "pnp_failed";
    case MatchOutcome::kTooFewInliers:
      return "too_few_inliers";
    case MatchOutcome::kLowInlierRatio:
      return "low_inlier_ratio";
  }
  return "unknown";
}

double pose_angle_deg(const SE3& a, const SE3& b) {
  return (a.so3() * b.so3().inverse()).angle() * 180.0 / std::numbers::pi;
}

double pose_distance_m(const SE3& a, const SE3& b) {
  return (a.inverse().translation() - b.inverse().translation()).norm();
}

ScanMatch match_to_rendering(const features::OrbFeatures& image,
                             const render::RenderResult& rendering, const SE3& rendering_pose,
                             const PinholeCamera& camera, features::OrbExtractor& extractor,
                             const ScanMatchOptions& o) {
  o.check();
  if (rendering.colour.cols != camera.width || rendering.colour.rows != camera.height)
    throw Error("the rendering's size differs from the camera's", {.field = "rendering"});
  ScanMatch out;
  out.image_features = image.size();
  cv::Mat grey;
  cv::cvtColor(rendering.colour, grey, cv::COLOR_RGB2GRAY);
  const features::OrbFeatures rf = extractor.extract(grey);
  out.rendered_features = rf.size();
  if (rf.size() < static_cast<std::size_t>(o.min_inliers)) return out;

  out.matches = guided_matches(image, rf, rendering, rendering_pose, camera, o);
  if (out.matches.size() < static_cast<std::size_t>(o.min_inliers)) {
    out.outcome = MatchOutcome::kTooFewMatches;
    return out;
  }
  if (!solve_pose(out, camera, o)) {
    out.outcome = MatchOutcome::kPnpFailed;
    return out;
  }
  classify(out, o);
  return out;
}

}  // namespace coloc::registration::align
