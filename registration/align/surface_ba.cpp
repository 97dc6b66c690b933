#include "registration/align/surface_ba.hpp"

#include <ceres/loss_function.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "registration/align/ba_terms.hpp"
#include "slam/core/error.hpp"
#include "slam/core/timing.hpp"
#include "slam/optim/bundle_adjustment.hpp"

namespace coloc::registration::align {

namespace optim = slam::optim;

namespace {

struct PointTerm {
  std::uint32_t point = 0;
  SurfaceHit hit;
};

struct DepthTerm {
  std::uint32_t pose = 0;
  Eigen::Vector3d p_cam = Eigen::Vector3d::Zero();
  SurfaceHit hit;
  double inv_sigma = 0.0;
};

struct Association {
  std::vector<PointTerm> points;
  std::vector<DepthTerm> depth;
};

double plane_distance(const SurfaceHit& hit, const Eigen::Vector3d& x) {
  return hit.normal.dot(x - hit.point);
}

// Depth samples by window pose, with the whitening that caps a keyframe's pull.
struct PoseSamples {
  std::uint32_t pose = 0;
  const std::vector<Eigen::Vector3d>* points = nullptr;
  double inv_sigma = 0.0;
};

std::vector<PoseSamples> samples_by_pose(const slam::mapping::BaWindow& w,
                                         const KeyframeDepthSamples& samples,
                                         const SurfaceBaOptions& o) {
  std::vector<PoseSamples> out;
  for (std::size_t i = 0; i < w.pose_ids.size(); ++i) {
    const auto it = samples.find(w.pose_ids[i]);
    if (it == samples.end() || it->second.empty()) continue;
    const double n = static_cast<double>(it->second.size());
    const double share = std::min(1.0, o.depth_samples_effective / n);
    out.push_back({static_cast<std::uint32_t>(i), &it->second, std::sqrt(share) / o.depth_sigma_m});
  }
  return out;
}

Association associate(const BaState& s, const std::vector<PoseSamples>& samples,
                      const ScanSurface& surface, double gate) {
  Association a;
  for (std::size_t i = 0; i < s.points.size(); ++i) {
    if (const auto hit = surface.nearest(s.points[i], gate))
      a.points.push_back({static_cast<std::uint32_t>(i), *hit});
  }
  for (const PoseSamples& ps : samples) {
    const SE3 world_from_cam = s.cam_from_world(ps.pose).inverse();
    for (const Eigen::Vector3d& p : *ps.points) {
      if (const auto hit = surface.nearest(world_from_cam * p, gate))
        a.depth.push_back({ps.pose, p, *hit, ps.inv_sigma});
    }
  }
  return a;
}

double median_abs(std::vector<double> v) {
  if (v.empty()) return 0.0;
  for (double& x : v)
    x = std::abs(x);
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// Median distance of the association's depth samples (map points without samples) in `s`.
double median_distance(const Association& a, const BaState& s) {
  std::vector<double> d;
  if (!a.depth.empty()) {
    for (const DepthTerm& t : a.depth)
      d.push_back(plane_distance(t.hit, s.cam_from_world(t.pose).inverse() * t.p_cam));
  } else {
    for (const PointTerm& t : a.points)
      d.push_back(plane_distance(t.hit, s.points[t.point]));
  }
  return median_abs(std::move(d));
}

}  // namespace

void SurfaceBaOptions::check() const {
  if (gates_m.empty()) throw Error("needs at least one round", {.field = "gates_m"});
  for (double g : gates_m) {
    if (!(g > 0.0 && std::isfinite(g)))
      throw Error("must be positive numbers of metres", {.field = "gates_m"});
  }
  if (iterations < 1) throw Error("must be >= 1", {.field = "iterations"});
  if (!(point_sigma_m > 0.0)) throw Error("must be positive (metres)", {.field = "point_sigma_m"});
  if (!(depth_sigma_m > 0.0)) throw Error("must be positive (metres)", {.field = "depth_sigma_m"});
  if (!(depth_samples_effective >= 1.0))
    throw Error("must be >= 1", {.field = "depth_samples_effective"});
  if (!(huber_chi2 > 0.0)) throw Error("must be positive", {.field = "huber_chi2"});
  if (!(chi2_stereo > 0.0)) throw Error("must be positive", {.field = "chi2_stereo"});
  if (!(chi2_mono > 0.0)) throw Error("must be positive", {.field = "chi2_mono"});
  if (threads < 1) throw Error("must be >= 1", {.field = "threads"});
}

bool PointToPlaneCost::Evaluate(double const* const* parameters, double* residuals,
                                double** jacobians) const {
  const Eigen::Map<const Eigen::Vector3d> x(parameters[0]);
  residuals[0] = inv_sigma_ * n_.dot(x - q_);
  if (jacobians && jacobians[0]) {
    Eigen::Map<Eigen::RowVector3d> j(jacobians[0]);
    j = inv_sigma_ * n_.transpose();
  }
  return true;
}

bool DepthToPlaneCost::Evaluate(double const* const* parameters, double* residuals,
                                double** jacobians) const {
  const SE3 cam_from_world = optim::pose_from_array(parameters[0]);
  const Eigen::Vector3d world = cam_from_world.inverse() * p_cam_;
  residuals[0] = inv_sigma_ * n_.dot(world - q_);
  if (jacobians && jacobians[0]) {
    // world = R^T (p - t); under cam_from_world <- exp(delta) * cam_from_world the world point
    // moves by -R^T d(exp(delta) p) / d delta = -R^T [I, -[p]x].
    const Eigen::Matrix3d world_from_cam_rotation = cam_from_world.so3().matrix().transpose();
    Eigen::Map<Eigen::Matrix<double, 1, 7, Eigen::RowMajor>> j(jacobians[0]);
    j.leftCols<6>() =
        -inv_sigma_ * n_.transpose() * world_from_cam_rotation * optim::pcam_jacobian_pose(p_cam_);
    j(0, 6) = 0.0;
  }
  return true;
}

SurfaceBaReport surface_bundle_adjustment(slam::map::Map& map, const ScanSurface& surface,
                                          const Camera& camera, const KeyframeDepthSamples& samples,
                                          const SurfaceBaOptions& o,
                                          const SurfaceBaMarkers& markers) {
  o.check();
  if (markers.corners) markers.options.check();
  Stopwatch watch;
  slam::mapping::BaWindow w = whole_map_window(map);
  for (auto& pose : w.problem.poses)
    pose.fixed = false;  // the surface holds the gauge
  const optim::Intrinsics& k = w.intrinsics;
  const std::vector<PoseSamples> pose_samples = samples_by_pose(w, samples, o);

  SurfaceBaReport report;
  BaState s = BaState::of(w.problem);
  std::vector<std::uint8_t> skip(w.problem.observations.size(), 0);
  report.initial_point_rms_px = reprojection_rms_px(w.problem, s, k, skip);
  const double delta = std::sqrt(o.huber_chi2);
  for (std::size_t round = 0; round < o.gates_m.size(); ++round) {
    const bool last = round + 1 == o.gates_m.size();
    // Before the last round, drop the map-point observations the map no longer agrees with
    // (as the marker BA and ORB-SLAM do), so the final solve runs on inliers.
    if (last && round > 0)
      skip = classify_observations(w.problem, s, k, o.chi2_stereo, o.chi2_mono, nullptr);
    const Association a = associate(s, pose_samples, surface, o.gates_m[round]);
    SurfaceBaRound r;
    r.gate_m = o.gates_m[round];
    r.point_terms = a.points.size();
    r.depth_terms = a.depth.size();
    r.median_before_m = median_distance(a, s);

    ceres::Problem cp(ba_problem_options());
    PoseBlocks pose_block(cp, w.problem, s);
    add_reprojection_terms(cp, w.problem, k, skip, delta, s, pose_block);
    for (const PointTerm& t : a.points) {
      cp.AddResidualBlock(new PointToPlaneCost(t.hit.point, t.hit.normal, 1.0 / o.point_sigma_m),
                          new ceres::HuberLoss(delta), s.points[t.point].data());
    }
    for (const DepthTerm& t : a.depth) {
      cp.AddResidualBlock(new DepthToPlaneCost(t.p_cam, t.hit.point, t.hit.normal, t.inv_sigma),
                          new ceres::HuberLoss(delta), pose_block(t.pose));
    }
    if (markers.corners) {
      report.marker_observations = add_marker_corner_terms(
          cp, map, w, *markers.corners, camera, markers.use_ids, markers.options, pose_block);
    }
    r.iterations = solve_ba(cp, o.iterations, o.threads);
    r.median_after_m = median_distance(a, s);
    report.rounds.push_back(r);
  }
  report.final_point_rms_px = reprojection_rms_px(w.problem, s, k, skip);
  write_back(map, w, s, skip);

  report.keyframes = w.pose_ids.size();
  report.points = w.point_ids.size();
  report.observations = w.problem.observations.size();
  for (const PoseSamples& ps : pose_samples)
    report.depth_samples += ps.points->size();
  report.outliers = static_cast<std::size_t>(std::count(skip.begin(), skip.end(), 1));
  report.ms = watch.elapsed_ms();
  return report;
}

std::string surface_ba_json(const SurfaceBaReport& b) {
  using Json = nlohmann::ordered_json;
  Json rounds = Json::array();
  for (const SurfaceBaRound& round : b.rounds) {
    rounds.push_back({{"gate_m", round.gate_m},
                      {"point_terms", round.point_terms},
                      {"depth_terms", round.depth_terms},
                      {"median_distance_m", {round.median_before_m, round.median_after_m}},
                      {"iterations", round.iterations}});
  }
  return Json{{"keyframes", b.keyframes},
              {"points", b.points},
              {"observations", b.observations},
              {"depth_samples", b.depth_samples},
              {"marker_observations", b.marker_observations},
              {"outliers", b.outliers},
              {"point_rms_px", {b.initial_point_rms_px, b.final_point_rms_px}},
              {"rounds", rounds},
              {"ms", b.ms}}
      .dump();
}

}  // namespace coloc::registration::align
