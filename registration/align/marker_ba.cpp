#include "registration/align/marker_ba.hpp"

#include <ceres/loss_function.h>
#include <ceres/problem.h>
#include <ceres/solver.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <unordered_map>

#include "registration/align/ba_terms.hpp"
#include "slam/core/error.hpp"
#include "slam/core/timing.hpp"
#include "slam/mapping/ba_window.hpp"
#include "slam/optim/bundle_adjustment.hpp"

namespace coloc::registration::align {

namespace optim = slam::optim;

namespace {

struct CornerObservation {
  std::uint32_t pose = 0;
  std::size_t marker = 0;  // index into MarkerTerms::ids
  int corner = 0;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();  // undistorted
};

struct ScanPointTerm {
  std::uint32_t pose = 0;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();  // undistorted
  Eigen::Vector3d world = Eigen::Vector3d::Zero();  // fixed, scan frame
};

struct MarkerTerms {
  std::vector<ScanPointTerm> scan_points;  // the refinement's 2-D/3-D matches (refine.hpp)
  std::vector<int> ids;
  std::vector<std::array<Eigen::Vector3d, 4>> corners;  // fixed, scan frame
  std::vector<std::size_t> keyframes;                   // per marker
  std::vector<CornerObservation> observations;
};

MarkerTerms marker_terms(const slam::map::Map& map, const slam::mapping::BaWindow& w,
                         const ScanCorners& scan, const Camera& camera,
                         const std::vector<int>& use_ids) {
  MarkerTerms t;
  std::map<int, std::size_t> index;
  for (std::size_t pose = 0; pose < w.pose_ids.size(); ++pose) {
    const slam::map::Keyframe* kf = map.keyframe(w.pose_ids[pose]);
    for (const markers::MarkerObservation& o : kf->markers) {
      const auto it = scan.find(o.id);
      if (it == scan.end()) continue;
      if (!use_ids.empty() && std::find(use_ids.begin(), use_ids.end(), o.id) == use_ids.end())
        continue;
      auto [slot, fresh] = index.emplace(o.id, t.ids.size());
      if (fresh) {
        t.ids.push_back(o.id);
        t.corners.push_back(it->second);
        t.keyframes.push_back(0);
      }
      ++t.keyframes[slot->second];
      for (int c = 0; c < 4; ++c) {
        const Eigen::Vector2d px = undistort_pixel(camera, o.corners[static_cast<std::size_t>(c)]);
        if (!px.allFinite()) continue;
        t.observations.push_back({static_cast<std::uint32_t>(pose), slot->second, c, px});
      }
    }
  }
  return t;
}

struct Flags {
  std::vector<std::uint8_t> skip;      // per map-point observation
  std::vector<std::uint8_t> rejected;  // per marker
};

// The marker corners (markers not rejected) and the scan points as terms on the poses.
void add_marker_terms(ceres::Problem& cp, const optim::Intrinsics& k, const MarkerTerms& markers,
                      const std::vector<std::uint8_t>& rejected, const MarkerBaOptions& o,
                      PoseBlocks& pose_block) {
  const double delta = std::sqrt(o.huber_chi2);
  const double marker_inv_sigma = std::sqrt(o.marker_weight) / o.marker_sigma_px;
  if (marker_inv_sigma > 0.0) {
    for (const CornerObservation& c : markers.observations) {
      if (rejected[c.marker]) continue;
      cp.AddResidualBlock(
          new MarkerCornerCost(k, c.pixel,
                               markers.corners[c.marker][static_cast<std::size_t>(c.corner)],
                               marker_inv_sigma),
          new ceres::HuberLoss(delta), pose_block(c.pose));
    }
  }
  const double scan_inv_sigma = 1.0 / o.scan_point_sigma_px;
  for (const ScanPointTerm& t : markers.scan_points) {
    cp.AddResidualBlock(new MarkerCornerCost(k, t.pixel, t.world, scan_inv_sigma),
                        new ceres::HuberLoss(delta), pose_block(t.pose));
  }
}

int solve(const optim::BundleProblem& problem, BaState& s, const optim::Intrinsics& k,
          const MarkerTerms& markers, const Flags& flags, const MarkerBaOptions& o) {
  ceres::Problem cp(ba_problem_options());
  PoseBlocks pose_block(cp, problem, s);
  const double delta = std::sqrt(o.huber_chi2);
  add_reprojection_terms(cp, problem, k, flags.skip, delta, s, pose_block);
  add_marker_terms(cp, k, markers, flags.rejected, o, pose_block);
  return solve_ba(cp, o.iterations, o.threads);
}

// Per marker: RMS pixel distance between detected and projected corners (behind the camera
// counts as 1000 px).
std::vector<double> marker_rms(const BaState& s, const optim::Intrinsics& k, const MarkerTerms& m) {
  std::vector<double> sum(m.ids.size(), 0.0);
  std::vector<std::size_t> n(m.ids.size(), 0);
  for (const CornerObservation& c : m.observations) {
    const SE3 pose = s.cam_from_world(c.pose);
    Eigen::Vector2d r;
    const bool ok = optim::mono_residual(
        k, pose * m.corners[c.marker][static_cast<std::size_t>(c.corner)], c.pixel, r, nullptr);
    sum[c.marker] += ok ? r.squaredNorm() : 1e6;
    ++n[c.marker];
  }
  std::vector<double> out(m.ids.size(), 0.0);
  for (std::size_t i = 0; i < out.size(); ++i)
    out[i] = n[i] ? std::sqrt(sum[i] / static_cast<double>(n[i])) : 0.0;
  return out;
}

// RMS over the markers' corner observations, weighted by their count, of the markers kept.
double pooled_marker_rms(const std::vector<double>& rms, const MarkerTerms& m,
                         const std::vector<std::uint8_t>& rejected) {
  double sum = 0.0, n = 0.0;
  for (std::size_t i = 0; i < rms.size(); ++i) {
    if (rejected[i]) continue;
    const double count = 4.0 * static_cast<double>(m.keyframes[i]);
    sum += rms[i] * rms[i] * count;
    n += count;
  }
  return n > 0.0 ? std::sqrt(sum / n) : 0.0;
}

// Largest RMS (pixels) among the markers not rejected, `except` left out too.
double worst_kept(const std::vector<double>& rms, const std::vector<std::uint8_t>& rejected,
                  std::size_t except) {
  double worst = 0.0;
  for (std::size_t i = 0; i < rms.size(); ++i) {
    if (!rejected[i] && i != except) worst = std::max(worst, rms[i]);
  }
  return worst;
}

// When some kept marker in state `s` exceeds the gate, finds the marker to blame by leaving each
// kept one out in turn (BA from the initial map without it): the culprit is the one that, left
// out, exceeds the gate itself while the others agree best (smallest worst RMS; the first that
// brings them all within the gate, trying the largest RMS first). A moved marker
// seen by many keyframes can drag the map so that an innocent, less observed marker shows the
// disagreement; leaving one out at a time tells them apart. Rejects it and puts its
// leave-one-out solution into `s`. False when all kept markers are within the gate, no
// leave-one-out explains the disagreement, or two markers would remain.
bool find_culprit(const optim::BundleProblem& problem, const BaState& initial,
                  const optim::Intrinsics& k, const MarkerTerms& markers, const MarkerBaOptions& o,
                  Flags& flags, BaState& s, MarkerBaReport& report) {
  const std::vector<double> rms = marker_rms(s, k, markers);
  const auto kept =
      static_cast<std::size_t>(std::count(flags.rejected.begin(), flags.rejected.end(), 0));
  if (worst_kept(rms, flags.rejected, rms.size()) <= o.marker_gate_px || kept <= 2) return false;
  // Most suspect first (largest RMS now). A trial that explains everything (the marker left out
  // exceeds the gate, every other kept one is within it) ends the search: each trial is a BA of
  // the whole map, and a site has 50+ markers (one marker 200 px off cost 56 trials, 15 min, at
  // 1,462 keyframes, where the first trial was the answer).
  std::vector<std::size_t> order;
  for (std::size_t c = 0; c < markers.ids.size(); ++c)
    if (!flags.rejected[c]) order.push_back(c);
  std::stable_sort(order.begin(), order.end(),
                   [&rms](std::size_t a, std::size_t b) { return rms[a] > rms[b]; });
  std::optional<std::size_t> culprit;
  double best_worst = 0.0;
  BaState best_state;
  for (std::size_t c : order) {
    if (culprit && best_worst <= o.marker_gate_px) break;
    BaState trial = initial;  // no bend left behind by the marker left out
    flags.rejected[c] = 1;
    report.iterations += solve(problem, trial, k, markers, flags, o);
    ++report.rounds;
    flags.rejected[c] = 0;
    const std::vector<double> r = marker_rms(trial, k, markers);
    const double worst = worst_kept(r, flags.rejected, c);
    if (r[c] > o.marker_gate_px && (!culprit || worst < best_worst)) {
      culprit = c;
      best_worst = worst;
      best_state = std::move(trial);
    }
  }
  if (!culprit) return false;
  flags.rejected[*culprit] = 1;
  s = std::move(best_state);
  return true;
}

}  // namespace

void MarkerBaOptions::check() const {
  if (!(scan_point_sigma_px > 0.0))
    throw Error("must be positive (pixels)", {.field = "scan_point_sigma_px"});
  if (iterations < 1) throw Error("must be >= 1", {.field = "iterations"});
  if (max_rounds < 1) throw Error("must be >= 1", {.field = "max_rounds"});
  if (!(huber_chi2 > 0.0)) throw Error("must be positive", {.field = "huber_chi2"});
  if (!(chi2_stereo > 0.0)) throw Error("must be positive", {.field = "chi2_stereo"});
  if (!(chi2_mono > 0.0)) throw Error("must be positive", {.field = "chi2_mono"});
  if (!(marker_sigma_px > 0.0))
    throw Error("must be positive (pixels)", {.field = "marker_sigma_px"});
  if (!(marker_weight >= 0.0)) throw Error("must be >= 0", {.field = "marker_weight"});
  if (!(marker_gate_px > 0.0))
    throw Error("must be positive (pixels)", {.field = "marker_gate_px"});
  if (threads < 1) throw Error("must be >= 1", {.field = "threads"});
}

std::vector<int> MarkerBaReport::rejected_ids() const {
  std::vector<int> ids;
  for (const MarkerBaMarker& m : markers) {
    if (m.rejected) ids.push_back(m.id);
  }
  return ids;
}

bool MarkerBaReport::usable() const {
  return std::count_if(markers.begin(), markers.end(),
                       [](const MarkerBaMarker& m) { return !m.rejected; }) >= 2;
}

bool MarkerCornerCost::Evaluate(double const* const* parameters, double* residuals,
                                double** jacobians) const {
  const SE3 pose = optim::pose_from_array(parameters[0]);
  const Eigen::Vector3d p = pose * corner_;
  Eigen::Vector2d r;
  Eigen::Matrix<double, 2, 3> jr;
  if (!optim::mono_residual(k_, p, pixel_, r, &jr)) {
    // Behind the camera: large constant residual, zero slope (as slam/optim's costs).
    residuals[0] = residuals[1] = 1e3;
    if (jacobians && jacobians[0]) std::fill(jacobians[0], jacobians[0] + 14, 0.0);
    return true;
  }
  residuals[0] = inv_sigma_ * r.x();
  residuals[1] = inv_sigma_ * r.y();
  if (jacobians && jacobians[0]) {
    Eigen::Map<Eigen::Matrix<double, 2, 7, Eigen::RowMajor>> j(jacobians[0]);
    j.leftCols<6>() = inv_sigma_ * jr * optim::pcam_jacobian_pose(p);
    j.col(6).setZero();
  }
  return true;
}

MarkerBaReport marker_bundle_adjustment(slam::map::Map& map, const ScanCorners& scan,
                                        const Camera& camera, const std::vector<int>& use_ids,
                                        const MarkerBaOptions& o,
                                        const std::unordered_set<KeyframeId>& fixed_keyframes,
                                        const std::vector<ScanPointObservation>& scan_points) {
  o.check();
  Stopwatch watch;
  slam::mapping::BaWindow w = whole_map_window(map);
  for (std::size_t i = 0; i < w.problem.poses.size(); ++i) {
    // The fixed marker corners hold the gauge; refined keyframes are held where PnP put them.
    w.problem.poses[i].fixed = fixed_keyframes.contains(w.pose_ids[i]);
  }
  MarkerTerms markers = marker_terms(map, w, scan, camera, use_ids);
  {
    std::unordered_map<KeyframeId, std::uint32_t> pose_of_id;
    for (std::size_t i = 0; i < w.pose_ids.size(); ++i)
      pose_of_id.emplace(w.pose_ids[i], static_cast<std::uint32_t>(i));
    for (const ScanPointObservation& p : scan_points) {
      const auto it = pose_of_id.find(p.keyframe);
      if (it != pose_of_id.end()) markers.scan_points.push_back({it->second, p.pixel, p.world});
    }
  }
  const optim::Intrinsics& k = w.intrinsics;

  const BaState initial = BaState::of(w.problem);
  BaState s = initial;
  Flags flags{std::vector<std::uint8_t>(w.problem.observations.size(), 0),
              std::vector<std::uint8_t>(markers.ids.size(), 0)};
  MarkerBaReport report;
  const std::vector<double> rms0 = marker_rms(initial, k, markers);
  report.initial_point_rms_px = reprojection_rms_px(w.problem, initial, k, flags.skip);
  report.initial_marker_rms_px = pooled_marker_rms(rms0, markers, flags.rejected);

  report.iterations += solve(w.problem, s, k, markers, flags, o);
  ++report.rounds;
  for (int round = 0; round < o.max_rounds; ++round) {
    if (!find_culprit(w.problem, initial, k, markers, o, flags, s, report)) break;
  }
  // Drop the map-point outliers and finish without them.
  flags.skip = classify_observations(w.problem, s, k, o.chi2_stereo, o.chi2_mono, nullptr);
  report.iterations += solve(w.problem, s, k, markers, flags, o);
  ++report.rounds;
  report.final_point_rms_px = reprojection_rms_px(w.problem, s, k, flags.skip);
  const std::vector<double> rms1 = marker_rms(s, k, markers);
  report.initial_marker_rms_px = pooled_marker_rms(rms0, markers, flags.rejected);
  report.final_marker_rms_px = pooled_marker_rms(rms1, markers, flags.rejected);
  for (std::size_t i = 0; i < markers.ids.size(); ++i) {
    report.markers.push_back(
        {markers.ids[i], markers.keyframes[i], rms0[i], rms1[i], flags.rejected[i] != 0});
  }
  std::sort(report.markers.begin(), report.markers.end(),
            [](const MarkerBaMarker& a, const MarkerBaMarker& b) { return a.id < b.id; });

  write_back(map, w, s, flags.skip);

  report.keyframes = w.pose_ids.size();
  report.points = w.point_ids.size();
  report.observations = w.problem.observations.size();
  report.marker_observations = markers.observations.size();
  report.outliers = static_cast<std::size_t>(std::count(flags.skip.begin(), flags.skip.end(), 1));
  report.ms = watch.elapsed_ms();
  return report;
}

std::size_t add_marker_corner_terms(ceres::Problem& problem, const slam::map::Map& map,
                                    const slam::mapping::BaWindow& window, const ScanCorners& scan,
                                    const Camera& camera, const std::vector<int>& use_ids,
                                    const MarkerBaOptions& options, PoseBlocks& poses) {
  const MarkerTerms markers = marker_terms(map, window, scan, camera, use_ids);
  add_marker_terms(problem, window.intrinsics, markers,
                   std::vector<std::uint8_t>(markers.ids.size(), 0), options, poses);
  return markers.observations.size();
}

}  // namespace coloc::registration::align
