// coloc eval frame-limit: how well can ANY global-shutter frame-to-frame tracker do on this
// sequence? For each frame, the previous frame is placed at its ground-truth pose, its keypoints
// with depth become 3-D points, and the frame's pose is solved from descriptor matches with the
// tracker's own pose optimizer (Huber, chi2 rounds), starting from the truth. What remains is
// the error the data impose: motion blur, rolling shutter, colour/depth time offsets, depth
// noise, ground-truth noise. A SLAM result far above this limit leaves room for the method; one
// near it does not. With a rolling-shutter readout time (Camera.readoutTime or --readout), the
// keypoints are compensated with the ground-truth rotation rate first: scanning --readout shows
// the camera's readout time (TUM fr1's Kinect: about 20 ms).

#include <cmath>
#include <cstdio>
#include <iostream>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/slam_inputs.hpp"
#include "Examples/coloc/verbs.hpp"
#include "slam/core/error.hpp"
#include "slam/core/progress.hpp"
#include "slam/core/timing.hpp"
#include "slam/features/orb_extractor.hpp"
#include "slam/frame/frame.hpp"
#include "slam/matching/search.hpp"
#include "slam/optim/pose_optimizer.hpp"

namespace coloc::cli {
namespace {

namespace fs = std::filesystem;

struct FrameLimitArgs {
  fs::path sequence, config;
  double window_px = 120.0;  // search window for matches (fast rotation moves ~50 px/frame)
  double readout = -1.0;     // seconds; < 0: the settings' Camera.readoutTime
  bool json = false;
};

// world_from_cam at time t, linearly interpolated (SE3 geodesic) between ground-truth samples.
std::optional<SE3> pose_at(const Trajectory& gt, double t) {
  auto it = std::lower_bound(gt.begin(), gt.end(), t,
                             [](const StampedPose& p, double x) { return p.timestamp < x; });
  if (it == gt.end() || it == gt.begin()) return std::nullopt;
  const StampedPose& b = *it;
  const StampedPose& a = *(it - 1);
  if (b.timestamp - a.timestamp > 0.1) return std::nullopt;  // a gap in the ground truth
  return interpolate(a.world_from_cam, b.world_from_cam,
                     (t - a.timestamp) / (b.timestamp - a.timestamp));
}

// Mutual-free nearest-descriptor matching of prev's keypoints with depth into cur: same or
// neighbouring level, within the window, Hamming <= TH_LOW and Lowe's ratio 0.8.
std::vector<slam::optim::PoseObservation> observations(const slam::frame::Frame& prev,
                                                       const slam::frame::Frame& cur,
                                                       double window) {
  std::vector<slam::optim::PoseObservation> obs;
  const auto& g = cur.geometry();
  for (std::size_t i = 0; i < prev.size(); ++i) {
    if (!prev.has_depth(i)) continue;
    const auto& kp = prev.features.keypoints[i];
    slam::features::NearestTwo nearest;
    for (std::size_t j :
         cur.features_in_area(kp.ux, kp.uy, window, std::max(0, kp.level - 1), kp.level + 1)) {
      nearest.offer(slam::features::hamming_distance(prev.features.descriptors[i],
                                                     cur.features.descriptors[j]),
                    j);
    }
    if (nearest.best > slam::matching::kDescriptorLow || nearest.best > 0.8 * nearest.second)
      continue;
    const std::size_t best_j = nearest.index;
    slam::optim::PoseObservation o;
    o.world = prev.unproject_world(i);
    o.pixel = cur.pixel(best_j);
    o.u_right = cur.u_right[best_j];
    o.inv_sigma2 = 1.0 / g.level_sigma2[static_cast<std::size_t>(cur.level(best_j))];
    obs.push_back(o);
  }
  return obs;
}

// Per frame pair: rotation (deg) and translation (mm) error, pose-optimizer inliers.
struct FrameLimit {
  std::vector<double> rot_deg, trans_mm, inliers;
  std::vector<std::pair<double, std::size_t>> worst;  // translation error, frame index
};

FrameLimit measure(const SlamInputs& in, double window_px, double readout) {
  const dataset::Sequence& seq = *in.sequence;
  const auto& orb = in.settings.orb;
  slam::features::OrbExtractor extractor(slam::features::ExtractorOptions{
      orb.n_features, orb.scale_factor, orb.n_levels, orb.ini_th_fast, orb.min_th_fast});
  std::shared_ptr<slam::frame::FrameGeometry> geometry;
  std::optional<slam::frame::Frame> prev;
  FrameLimit out;
  Progress progress("frame-limit", seq.size());
  for (std::size_t k = 0; k < seq.size(); ++k) {
    const auto f = seq.frame(k);
    progress.set(k + 1);
    const auto world_from_cam = pose_at(seq.ground_truth(), f.timestamp);
    if (!world_from_cam) {
      prev.reset();
      continue;
    }
    if (!geometry) {
      Camera camera = in.settings.camera;
      std::visit(
          [&](auto& c) {
            c.width = f.color.cols;
            c.height = f.color.rows;
          },
          camera);
      geometry = std::make_shared<slam::frame::FrameGeometry>(slam::frame::FrameGeometry::make(
          camera, in.settings.depth->bf, in.settings.depth->close_depth,
          extractor.scale_factors()));
      geometry->readout = readout;
    }
    cv::Mat grey = f.color;
    if (grey.channels() == 3) cv::cvtColor(f.color, grey, cv::COLOR_BGR2GRAY);
    slam::frame::Frame cur(FrameId(k + 1), f.timestamp,
                           extractor.extract(grey, &in.settings.camera), f.depth, geometry);
    cur.cam_from_world = world_from_cam->inverse();
    cur.has_pose = true;
    if (readout > 0.0) {
      // The true rotation rate at the frame's time, camera frame (central difference).
      const auto before = pose_at(seq.ground_truth(), f.timestamp - 0.01);
      const auto after = pose_at(seq.ground_truth(), f.timestamp + 0.01);
      if (before && after)
        cur.compensate_rolling_shutter((before->so3().inverse() * after->so3()).log() / 0.02,
                                       f.color.rows);
    }
    const auto obs =
        prev ? observations(*prev, cur, window_px) : std::vector<slam::optim::PoseObservation>{};
    if (obs.size() >= 10) {
      const slam::optim::Intrinsics intr{geometry->fx, geometry->fy, geometry->cx, geometry->cy,
                                         geometry->bf};
      const auto r = slam::optim::optimize_pose(cur.cam_from_world, obs, intr);
      const SE3 err = r.cam_from_world * *world_from_cam;  // identity when exact
      out.rot_deg.push_back(err.so3().log().norm() * 180.0 / std::numbers::pi);
      out.trans_mm.push_back(1e3 * err.inverse().translation().norm());
      out.inliers.push_back(r.inliers);
      out.worst.emplace_back(out.trans_mm.back(), k);
    }
    prev = std::move(cur);
  }
  progress.finish();
  std::sort(out.worst.rbegin(), out.worst.rend());
  return out;
}

double rms(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v)
    s += x * x;
  return std::sqrt(s / static_cast<double>(v.size()));
}

void run_frame_limit(const FrameLimitArgs& args) {
  const SlamInputs in = load_slam_inputs(args.sequence, args.config);
  if (in.sequence->ground_truth().empty())
    throw Error("sequence has no ground truth", {args.sequence.string()});
  if (!in.settings.depth) throw Error("settings without depth (Camera.bf)", {in.config.string()});
  const double readout = args.readout >= 0.0 ? args.readout : in.settings.readout_time;
  const FrameLimit f = measure(in, args.window_px, readout);
  if (f.rot_deg.empty())
    throw Error("no frame pair with ground truth and depth", {args.sequence.string()});
  const SampleStats r = summarize(f.rot_deg), t = summarize(f.trans_mm), m = summarize(f.inliers);
  if (args.json) {
    std::cout << "{\"pairs\": " << f.rot_deg.size()
              << ", \"rotation_deg_rms\": " << json_number(rms(f.rot_deg))
              << ", \"rotation_deg_median\": " << json_number(r.median)
              << ", \"rotation_deg_max\": " << json_number(r.max)
              << ", \"translation_mm_rms\": " << json_number(rms(f.trans_mm))
              << ", \"translation_mm_median\": " << json_number(t.median)
              << ", \"translation_mm_max\": " << json_number(t.max)
              << ", \"inliers_median\": " << json_number(m.median)
              << ", \"readout_s\": " << json_number(readout) << "}\n";
    return;
  }
  std::printf(
      "frame-to-frame limit over %zu frame pairs (previous frame at its ground-truth pose), "
      "rolling-shutter readout %.1f ms\n",
      f.rot_deg.size(), 1e3 * readout);
  std::printf("  rotation    rms %.3f deg, median %.3f, max %.3f\n", rms(f.rot_deg), r.median,
              r.max);
  std::printf("  translation rms %.1f mm, median %.1f, max %.1f\n", rms(f.trans_mm), t.median,
              t.max);
  std::printf("  inliers     median %.0f, min %.0f\n", m.median, m.min);
  std::printf("  worst frames (index: translation mm):");
  for (std::size_t i = 0; i < std::min<std::size_t>(8, f.worst.size()); ++i)
    std::printf(" %zu: %.1f", f.worst[i].second, f.worst[i].first);
  std::printf("\n");
}

}  // namespace

void add_frame_limit_verb(CLI::App& eval) {
  auto args = std::make_shared<FrameLimitArgs>();
  CLI::App& cmd = *eval.add_subcommand(
      "frame-limit",
      "Error of a frame's pose solved from the previous frame placed at its ground truth: what "
      "the data allow any frame-to-frame tracker");
  cmd.add_option("sequence", args->sequence, "Sequence folder with ground truth")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd.add_option("--config", args->config, "Camera settings YAML (default: shipped file)");
  cmd.add_option("--window", args->window_px, "Match search window (pixels)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd.add_option("--readout", args->readout,
                 "Rolling-shutter readout time in seconds (default: Camera.readoutTime; 0 = off)")
      ->check(CLI::Range(0.0, 0.5));
  cmd.add_flag("--json", args->json, "Machine-readable output on stdout");
  cmd.callback([args] { run_frame_limit(*args); });
}

}  // namespace coloc::cli
