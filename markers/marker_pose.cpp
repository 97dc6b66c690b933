#include "markers/marker_pose.hpp"

#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <utility>
#include <vector>

#include "slam/core/error.hpp"

namespace coloc::markers {
namespace {

SE3 se3_from_rvec_tvec(const cv::Mat& rvec, const cv::Mat& tvec) {
  cv::Mat r;
  cv::Rodrigues(rvec, r);
  Eigen::Matrix3d rotation;
  cv::cv2eigen(r, rotation);
  Eigen::Vector3d translation;
  cv::cv2eigen(tvec, translation);
  return SE3(SO3::from_matrix(rotation), translation);
}

}  // namespace

void PoseOptions::check() const {
  if (!(marker_size > 0.0) || !std::isfinite(marker_size)) {
    throw Error("must be a positive edge length in metres", {.field = "marker_size"});
  }
  if (!(ambiguity_ratio >= 1.0)) throw Error("must be >= 1", {.field = "ambiguity_ratio"});
  if (!(ambiguity_error_px >= 0.0)) throw Error("must be >= 0", {.field = "ambiguity_error_px"});
}

double MarkerPose::candidate_angle() const {
  return rotation_distance(best.camera_from_marker, alternative.camera_from_marker);
}

std::array<Eigen::Vector3d, 4> marker_corners(double marker_size) {
  const double h = 0.5 * marker_size;
  return {Eigen::Vector3d(-h, h, 0.0), Eigen::Vector3d(h, h, 0.0), Eigen::Vector3d(h, -h, 0.0),
          Eigen::Vector3d(-h, -h, 0.0)};
}

double reprojection_error(const Camera& camera, const SE3& camera_from_marker,
                          const MarkerObservation& observation, double marker_size) {
  const auto corners = marker_corners(marker_size);
  double sum_sq = 0.0;
  for (int c = 0; c < 4; ++c) {
    const Eigen::Vector3d p = camera_from_marker * corners[c];
    if (!(p.z() > 0.0)) return std::numeric_limits<double>::infinity();
    sum_sq += (project(camera, p) - observation.corners[c]).squaredNorm();
  }
  return std::sqrt(sum_sq / 4.0);
}

std::optional<MarkerPose> estimate_marker_pose(const Camera& camera,
                                               const MarkerObservation& observation,
                                               const PoseOptions& options) {
  options.check();
  // Distortion is removed first so that the PnP below runs on an ideal pinhole with the same
  // fx fy cx cy; the errors reported are measured with the full model.
  std::vector<cv::Point2d> image_points;
  for (const Eigen::Vector2d& corner : observation.corners) {
    const Eigen::Vector2d u = undistort_pixel(camera, corner);
    if (!u.allFinite()) return std::nullopt;
    image_points.emplace_back(u.x(), u.y());
  }
  std::vector<cv::Point3d> object_points;
  for (const Eigen::Vector3d& c : marker_corners(options.marker_size)) {
    object_points.emplace_back(c.x(), c.y(), c.z());
  }
  cv::Mat k;
  cv::eigen2cv(intrinsic_matrix(camera), k);
  const cv::Mat no_distortion;

  std::vector<cv::Mat> rvecs, tvecs;
  try {
    cv::solvePnPGeneric(object_points, image_points, k, no_distortion, rvecs, tvecs, false,
                        cv::SOLVEPNP_IPPE_SQUARE);
  } catch (const cv::Exception&) {
    return std::nullopt;  // degenerate corners (collinear, coincident): no pose, not an error
  }
  // Each IPPE solution, unrefined and refined. Refinement can slide the worse solution into the
  // better one's basin; we then keep it unrefined, so that the two hypotheses stay distinct.
  struct Hypothesis {
    PoseCandidate raw, refined;
  };
  std::vector<Hypothesis> hypotheses;
  for (std::size_t i = 0; i < rvecs.size(); ++i) {
    Hypothesis h;
    h.raw.camera_from_marker = se3_from_rvec_tvec(rvecs[i], tvecs[i]);
    cv::Mat rvec = rvecs[i].clone(), tvec = tvecs[i].clone();
    if (options.refine) {
      cv::solvePnPRefineLM(object_points, image_points, k, no_distortion, rvec, tvec);
    }
    h.refined.camera_from_marker = se3_from_rvec_tvec(rvec, tvec);
    for (PoseCandidate* c : {&h.raw, &h.refined}) {
      c->reprojection_error_px =
          reprojection_error(camera, c->camera_from_marker, observation, options.marker_size);
    }
    if (std::isfinite(h.refined.reprojection_error_px)) hypotheses.push_back(h);
  }
  if (hypotheses.empty()) return std::nullopt;
  if (hypotheses.size() == 1) hypotheses.push_back(hypotheses.front());
  if (hypotheses[1].refined.reprojection_error_px < hypotheses[0].refined.reprojection_error_px) {
    std::swap(hypotheses[0], hypotheses[1]);
  }
  std::array<PoseCandidate, 2> candidates{hypotheses[0].refined, hypotheses[1].refined};
  const double raw_angle =
      rotation_distance(hypotheses[0].raw.camera_from_marker, hypotheses[1].raw.camera_from_marker);
  const double refined_angle =
      rotation_distance(candidates[0].camera_from_marker, candidates[1].camera_from_marker);
  if (refined_angle < 0.25 * raw_angle) candidates[1] = hypotheses[1].raw;

  MarkerPose pose;
  pose.id = observation.id;
  pose.best = candidates[0];
  pose.alternative = candidates[1];
  const double plausible = std::max(options.ambiguity_ratio * pose.best.reprojection_error_px,
                                    options.ambiguity_error_px);
  pose.ambiguous = pose.alternative.reprojection_error_px < plausible;
  return pose;
}

MarkerPose choose_closest(const MarkerPose& pose, const SO3& prior_camera_from_marker) {
  const SE3 prior(prior_camera_from_marker, Eigen::Vector3d::Zero());
  const auto angle_to_prior = [&](const PoseCandidate& c) {
    return rotation_distance(SE3(c.camera_from_marker.so3(), Eigen::Vector3d::Zero()), prior);
  };
  MarkerPose out = pose;
  if (angle_to_prior(pose.alternative) < angle_to_prior(pose.best)) {
    std::swap(out.best, out.alternative);
  }
  return out;
}

}  // namespace coloc::markers
