#include "slam/localize/scan_anchor.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "slam/core/error.hpp"
#include "slam/core/parallel.hpp"

namespace coloc::slam::localize {

namespace {

using Matrix6 = Eigen::Matrix<double, 6, 6>;
using Vector6 = Eigen::Matrix<double, 6, 1>;

constexpr double kHuber = 1.5;  // standard deviations

// One Gauss-Newton system of point-to-plane residuals, in the left perturbation
// world_from_cam <- exp(omega, v) * world_from_cam with the unknowns ordered (omega, v).
struct Normal {
  Matrix6 h = Matrix6::Zero();
  Vector6 g = Vector6::Zero();
  int inliers = 0;
  double sse = 0.0;     // unweighted, metres^2
  double weight = 0.0;  // sum of the samples' weights
};

// The samples [begin, end) into `n`.
void accumulate_range(const SurfaceGrid& grid, SurfaceGrid::Resolution level,
                      const std::vector<Eigen::Vector3d>& points_cam, std::size_t begin,
                      std::size_t end, const SE3& world_from_cam, double gate,
                      const ScanAnchorOptions& o, Normal& n) {
  for (std::size_t i = begin; i < end; ++i) {
    const Eigen::Vector3d& p = points_cam[i];
    const Eigen::Vector3d y = world_from_cam * p;
    const Surfel* s = grid.nearest(level, y, gate);
    if (!s) continue;
    const Eigen::Vector3d normal = s->normal.cast<double>();
    const double r = normal.dot(y - s->point.cast<double>());
    // Weight 1 / sigma^2 with the depth's noise growing as z^2 (structured light and stereo
    // alike), Huber beyond 1.5 sigma.
    const double z2 = p.z() * p.z();
    const double sigma = std::sqrt(o.surface_sigma_m * o.surface_sigma_m +
                                   o.depth_sigma_at_1m * o.depth_sigma_at_1m * z2 * z2);
    const double a = std::abs(r) / sigma;
    const double w = (a <= kHuber ? 1.0 : kHuber / a) / (sigma * sigma);
    Vector6 j;
    j << y.cross(normal), normal;
    n.h.selfadjointView<Eigen::Lower>().rankUpdate(j, w);
    n.g += w * r * j;
    n.sse += r * r;
    n.weight += w;
    ++n.inliers;
  }
}

Normal accumulate(const SurfaceGrid& grid, const std::vector<Eigen::Vector3d>& points_cam,
                  const SE3& world_from_cam, double gate, const ScanAnchorOptions& o) {
  // Coarse surfels until the gate fits the fine level's 27-voxel block.
  const SurfaceGrid::Resolution level = gate > 2.0 * grid.options().fine_voxel_m
                                            ? SurfaceGrid::Resolution::kCoarse
                                            : SurfaceGrid::Resolution::kFine;
  // One share of the samples per thread, summed in a fixed order: the result does not depend
  // on the thread count's timing.
  const std::size_t shares = static_cast<std::size_t>(worker_count(o.threads));
  std::vector<Normal> parts(shares);
  const std::size_t per = (points_cam.size() + shares - 1) / shares;
  parallel_for(shares, o.threads, [&](std::size_t k) {
    accumulate_range(grid, level, points_cam, k * per, std::min(points_cam.size(), (k + 1) * per),
                     world_from_cam, gate, o, parts[k]);
  });
  Normal n;
  for (const Normal& part : parts) {
    n.h += part.h;
    n.g += part.g;
    n.inliers += part.inliers;
    n.sse += part.sse;
    n.weight += part.weight;
  }
  n.h = n.h.selfadjointView<Eigen::Lower>();
  return n;
}

// Whether two camera poses are within `metres` (centres) and `radians` (orientations).
bool within(const SE3& a, const SE3& b, double metres, double radians) {
  return (a.translation() - b.translation()).norm() <= metres &&
         (a.so3() * b.so3().inverse()).log().norm() <= radians;
}

ScanAnchorOptions checked(ScanAnchorOptions options) {
  options.check();
  return options;
}

}  // namespace

void ScanAnchorOptions::check() const {
  if (stride_px < 1) throw Error("ScanAnchorOptions.stride_px must be >= 1");
  if (threads < 0) throw Error("ScanAnchorOptions.threads must be >= 0");
  if (max_samples < min_inliers)
    throw Error("ScanAnchorOptions.max_samples must be >= min_inliers");
  if (!(min_depth_m > 0.0 && max_depth_m > min_depth_m))
    throw Error("ScanAnchorOptions: need 0 < min_depth_m < max_depth_m");
  if (!(surface_sigma_m > 0.0)) throw Error("ScanAnchorOptions.surface_sigma_m must be > 0");
  if (!(depth_sigma_at_1m >= 0.0)) throw Error("ScanAnchorOptions.depth_sigma_at_1m must be >= 0");
  for (const auto* gates : {&cold_gates, &tracking_gates}) {
    if (gates->empty()) throw Error("ScanAnchorOptions: a gate schedule is empty");
    for (const double g : *gates)
      if (!(g > 0.0)) throw Error("ScanAnchorOptions: gates must be > 0");
  }
  if (!(converged_step > 0.0)) throw Error("ScanAnchorOptions.converged_step must be > 0");
  if (!(prior_sigma_m > 0.0 && prior_sigma_rad > 0.0))
    throw Error("ScanAnchorOptions: prior sigmas must be > 0");
  if (min_inliers < 6) throw Error("ScanAnchorOptions.min_inliers must be >= 6");
  if (!(max_rms_m > 0.0)) throw Error("ScanAnchorOptions.max_rms_m must be > 0");
  if (!(min_inlier_ratio >= 0.0 && min_inlier_ratio <= 1.0))
    throw Error("ScanAnchorOptions.min_inlier_ratio must be in [0, 1]");
  if (!(max_tracking_step_m > 0.0 && max_tracking_step_rad > 0.0))
    throw Error("ScanAnchorOptions: max tracking steps must be > 0");
  if (!(max_cold_offset_m > 0.0 && max_cold_offset_rad > 0.0))
    throw Error("ScanAnchorOptions: max cold offsets must be > 0");
  if (!(max_offset_m > 0.0 && max_offset_rad > 0.0))
    throw Error("ScanAnchorOptions: max offsets must be > 0");
  grid.check();
}

DepthSampler::DepthSampler(const Camera& camera, int stride_px)
    : width_(image_width(camera)), height_(image_height(camera)) {
  if (width_ <= 0 || height_ <= 0 || stride_px < 1)
    throw Error("DepthSampler: the camera has no image size", {.field = "Camera.width"});
  for (int v = stride_px / 2; v < height_; v += stride_px)
    for (int u = stride_px / 2; u < width_; u += stride_px) {
      const Eigen::Vector3d ray = unproject(camera, Eigen::Vector2d(u, v));
      if (!(ray.z() > 1e-6)) continue;  // beyond a fisheye's half sphere
      pixels_.emplace_back(u, v);
      rays_.push_back(ray / ray.z());
    }
}

std::vector<Eigen::Vector3d> DepthSampler::points(const cv::Mat& depth, double min_m,
                                                  double max_m) const {
  if (depth.type() != CV_32FC1 || depth.cols != width_ || depth.rows != height_)
    throw Error("DepthSampler: depth must be CV_32FC1 of " + std::to_string(width_) + "x" +
                std::to_string(height_));
  std::vector<Eigen::Vector3d> out;
  out.reserve(pixels_.size());
  for (std::size_t i = 0; i < pixels_.size(); ++i) {
    const double z = depth.at<float>(pixels_[i].y(), pixels_[i].x());
    if (z >= min_m && z <= max_m) out.push_back(rays_[i] * z);
  }
  return out;
}

ScanAnchor::ScanAnchor(const std::vector<Eigen::Vector3f>& scan_points, ScanAnchorOptions options)
    : options_(checked(std::move(options))), grid_(scan_points, options_.grid) {}

std::optional<AnchorResult> ScanAnchor::align(const std::vector<Eigen::Vector3d>& samples,
                                              const SE3& start_world_from_cam,
                                              const SE3& visual_world_from_cam, bool cold) const {
  if (static_cast<int>(samples.size()) < options_.min_inliers) return std::nullopt;
  // Evenly thinned to max_samples (the samples are in image order: every k-th keeps the spread).
  std::vector<Eigen::Vector3d> thinned;
  const std::size_t max_samples = static_cast<std::size_t>(options_.max_samples);
  if (samples.size() > max_samples) {
    thinned.reserve(max_samples);
    const double step = static_cast<double>(samples.size()) / static_cast<double>(max_samples);
    for (std::size_t k = 0; k < max_samples; ++k)
      thinned.push_back(samples[static_cast<std::size_t>(static_cast<double>(k) * step)]);
  }
  const std::vector<Eigen::Vector3d>& points_cam = thinned.empty() ? samples : thinned;
  const std::vector<double>& gates = cold ? options_.cold_gates : options_.tracking_gates;
  Vector6 prior_w;
  prior_w << Eigen::Vector3d::Constant(1.0 / (options_.prior_sigma_rad * options_.prior_sigma_rad)),
      Eigen::Vector3d::Constant(1.0 / (options_.prior_sigma_m * options_.prior_sigma_m));

  SE3 world_from_cam = start_world_from_cam;
  Normal last;
  int iterations = 0;
  for (std::size_t k = 0; k < gates.size(); ++k) {
    last = accumulate(grid_, points_cam, world_from_cam, gates[k], options_);
    ++iterations;
    if (last.inliers < options_.min_inliers) return std::nullopt;
    // The prior's residual: this pose's left offset from the visual pose, (omega, v).
    const SE3 offset = world_from_cam * visual_world_from_cam.inverse();
    Vector6 e;
    e << offset.so3().log(), offset.translation();
    const Matrix6 h = last.h + Matrix6(prior_w.asDiagonal());
    const Vector6 g = last.g + prior_w.cwiseProduct(e);
    const Vector6 step = -h.ldlt().solve(g);
    if (!step.allFinite()) return std::nullopt;
    world_from_cam = SE3(SO3::exp(step.head<3>()), step.tail<3>()) * world_from_cam;
    if (step.head<3>().norm() < options_.converged_step &&
        step.tail<3>().norm() < options_.converged_step) {
      // Converged at this gate: on to the next smaller one, or done.
      while (k + 1 < gates.size() && gates[k + 1] >= gates[k])
        ++k;
    }
  }

  AnchorResult r;
  r.world_from_cam = world_from_cam;
  r.inliers = last.inliers;
  r.samples = static_cast<int>(points_cam.size());
  r.rms_m = std::sqrt(last.sse / std::max(1, last.inliers));
  r.iterations = iterations;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(last.h.bottomRightCorner<3, 3>());
  r.conditioning = last.weight > 0.0 ? eig.eigenvalues()[0] / last.weight : 0.0;
  if (r.rms_m > options_.max_rms_m ||
      r.inliers < options_.min_inlier_ratio * static_cast<double>(r.samples))
    return std::nullopt;
  // How far the alignment moved its start, and how far the result is from the visual pose.
  const bool step_ok = cold ? within(world_from_cam, start_world_from_cam,
                                     options_.max_cold_offset_m, options_.max_cold_offset_rad)
                            : within(world_from_cam, start_world_from_cam,
                                     options_.max_tracking_step_m, options_.max_tracking_step_rad);
  if (!step_ok || !within(world_from_cam, visual_world_from_cam, options_.max_offset_m,
                          options_.max_offset_rad))
    return std::nullopt;
  return r;
}

}  // namespace coloc::slam::localize
