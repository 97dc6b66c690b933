#include "slam/loop/verification.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "slam/core/align.hpp"
#include "slam/core/timing.hpp"
#include "slam/matching/pose_support.hpp"
#include "slam/matching/search.hpp"

namespace coloc::slam::loop {
namespace {

constexpr double kChi2Stereo = 7.815;  // 95 % of chi2 with 3 degrees of freedom

// One 3-D/3-D pair: a candidate-side map point (world) and the new keyframe's keypoint.
struct Pair {
  Eigen::Vector3d world;  // map point, metres
  Eigen::Vector3d cam;    // keypoint unprojected with its depth, camera frame
  std::size_t keypoint;
  MapPointId point;
};

bool reprojects(const frame::Frame& f, const SE3& cam_from_world, const Pair& p) {
  const auto& g = f.geometry();
  const Eigen::Vector3d pc = cam_from_world * p.world;
  if (pc.z() <= 0.0) return false;
  const Eigen::Vector2d uv = g.project(pc);
  const Eigen::Vector2d e = f.pixel(p.keypoint) - uv;
  const double er = f.u_right[p.keypoint] - (uv.x() - g.bf / pc.z());
  const double sigma2 = g.level_sigma2[static_cast<std::size_t>(f.level(p.keypoint))];
  return (e.squaredNorm() + er * er) / sigma2 < kChi2Stereo;
}

// RANSAC over minimal 3-pair Umeyama fits, then a refit on the best consensus.
std::vector<std::size_t> ransac_se3(const frame::Frame& f, const std::vector<Pair>& pairs,
                                    int iterations, std::mt19937& rng, SE3& best_pose) {
  std::vector<std::size_t> best;
  if (pairs.size() < 3) return best;
  std::uniform_int_distribution<std::size_t> pick(0, pairs.size() - 1);
  for (int it = 0; it < iterations; ++it) {
    const std::size_t a = pick(rng), b = pick(rng), c = pick(rng);
    if (a == b || b == c || a == c) continue;
    const AlignmentResult fit = align_points({pairs[a].world, pairs[b].world, pairs[c].world},
                                             {pairs[a].cam, pairs[b].cam, pairs[c].cam});
    if (!fit.usable) continue;
    const SE3 pose = fit.dst_from_src.to_se3();
    std::vector<std::size_t> inliers;
    for (std::size_t i = 0; i < pairs.size(); ++i)
      if (reprojects(f, pose, pairs[i])) inliers.push_back(i);
    if (inliers.size() > best.size()) {
      best = std::move(inliers);
      best_pose = pose;
    }
  }
  if (best.size() >= 3) {
    std::vector<Eigen::Vector3d> src, dst;
    for (std::size_t i : best) {
      src.push_back(pairs[i].world);
      dst.push_back(pairs[i].cam);
    }
    const AlignmentResult fit = align_points(src, dst);
    if (fit.usable) best_pose = fit.dst_from_src.to_se3();
  }
  return best;
}

int inlier_count(const frame::Frame& f) {
  int n = 0;
  for (std::size_t i = 0; i < f.size(); ++i)
    n += f.points[i].valid() && !f.outlier[i] ? 1 : 0;
  return n;
}

// Projection search of the group's points around `f`'s pose, then the pose refined on them:
// the inliers, with the outliers dropped from `f`.
int guided_search(const map::Map& map, const std::vector<KeyframeId>& group, const LoopOptions& o,
                  double radius_px, frame::Frame& f) {
  for (KeyframeId k : group)
    matching::search_keyframe_points(f, *map.keyframe(k), map, radius_px,
                                     o.projection_max_distance);
  matching::optimize_frame_pose(f, map);
  const int inliers = inlier_count(f);
  matching::drop_outliers(f);
  return inliers;
}

// Verified pose against the estimate: is this within the drift odometry can have had?
void plausibility(const map::Map& map, const map::Keyframe& cur, const LoopOptions& o,
                  LoopVerification& v) {
  const SE3 correction = v.corrected_cam_from_world.inverse() * cur.cam_from_world();
  v.path_m = path_length(map, v.candidate, v.current);
  v.correction_m = correction.translation().norm();
  v.correction_rad = correction.so3().log().norm();
  if (!plausible_correction(v.correction_m, v.correction_rad, v.path_m, o, &v.allowed_m,
                            &v.allowed_rad)) {
    v.rejection = "implausible correction (aliasing?)";
    v.implausible = true;
    return;
  }
  v.accepted = true;
}

}  // namespace

FreeSpaceCount free_space_against(const map::Map& map, const std::vector<KeyframeId>& near_current,
                                  const SE3& candidate_world_from_world,
                                  const std::vector<KeyframeId>& candidate_group,
                                  const Camera& camera, const FreeSpaceOptions& options) {
  // Each keyframe's samples are back-projected once, whatever the number of pairs it is in.
  std::unordered_map<KeyframeId, std::vector<Eigen::Vector3d>> samples;
  const auto samples_of = [&](const map::Keyframe& kf) -> const std::vector<Eigen::Vector3d>& {
    auto [it, added] = samples.try_emplace(kf.id);
    if (added) it->second = depth_samples(*kf.depth, camera, options);
    return it->second;
  };
  FreeSpaceCount count;
  for (KeyframeId c : near_current) {
    const map::Keyframe* here = map.keyframe(c);
    if (!here || !here->depth) continue;
    // This keyframe's pose in the candidate's frame, as the correction would place it.
    const SE3 world_from_here = candidate_world_from_world * here->cam_from_world().inverse();
    for (KeyframeId k : candidate_group) {
      const map::Keyframe* other = map.keyframe(k);
      if (!other || !other->depth || k == c) continue;
      const SE3 other_from_here = other->cam_from_world() * world_from_here;
      FreeSpaceCount pair =
          compare_depth(samples_of(*here), *other->depth, other_from_here, camera, options);
      pair += compare_depth(samples_of(*other), *here->depth, other_from_here.inverse(), camera,
                            options);
      if (pair.compared() >= FreeSpaceCount::kPairSamples) pair.worst_pair = pair.violation();
      count += pair;
    }
  }
  return count;
}

bool plausible_correction(double correction_m, double correction_rad, double path_m,
                          const LoopOptions& options, double* allowed_m, double* allowed_rad) {
  const double m = options.max_drift_m + options.max_drift_per_m * path_m;
  const double rad = options.max_rotation_drift + options.max_rotation_drift_per_m * path_m;
  if (allowed_m) *allowed_m = m;
  if (allowed_rad) *allowed_rad = rad;
  return correction_m <= m && correction_rad <= rad;
}

double path_length(const map::Map& map, KeyframeId from, KeyframeId to) {
  if (to < from) std::swap(from, to);
  std::vector<KeyframeId> ids;
  for (const auto& [id, kf] : map.keyframes())
    if (id >= from && id <= to) ids.push_back(id);
  std::sort(ids.begin(), ids.end());
  double length = 0.0;
  for (std::size_t i = 1; i < ids.size(); ++i)
    length +=
        (map.keyframe(ids[i])->camera_centre() - map.keyframe(ids[i - 1])->camera_centre()).norm();
  return length;
}

LoopVerification verify_loop(const map::Map& map, KeyframeId current, KeyframeId candidate,
                             const LoopOptions& o, std::mt19937& rng, const Camera* depth_camera) {
  LoopVerification v;
  v.current = current;
  v.candidate = candidate;
  const map::Keyframe* cur = map.keyframe(current);
  const map::Keyframe* cand = map.keyframe(candidate);
  if (!cur || !cand) {
    v.rejection = "keyframe gone";
    return v;
  }
  // A copy of the new keyframe's frame receives the candidate-side matches.
  frame::Frame f = cur->frame;
  f.points.assign(f.size(), MapPointId::invalid());
  f.outlier.assign(f.size(), 0);
  v.bow_matches = matching::search_by_bow(*cand, f, map);
  if (v.bow_matches < o.min_bow_matches) {
    v.rejection = "too few BoW matches";
    return v;
  }
  const auto& g = f.geometry();
  std::vector<Pair> pairs;
  for (std::size_t i = 0; i < f.size(); ++i) {
    if (!f.points[i].valid() || !f.has_depth(i)) continue;
    const double z = f.depth[i];
    const Eigen::Vector2d uv = f.pixel(i);
    pairs.push_back({map.point(f.points[i])->position,
                     {(uv.x() - g.cx) * z / g.fx, (uv.y() - g.cy) * z / g.fy, z},
                     i,
                     f.points[i]});
  }
  SE3 pose;
  const std::vector<std::size_t> inliers = ransac_se3(f, pairs, o.ransac_iterations, rng, pose);
  v.ransac_inliers = static_cast<int>(inliers.size());
  if (v.ransac_inliers < o.min_ransac_inliers) {
    v.rejection = "too few RANSAC inliers";
    return v;
  }
  // Keep the consensus only, refine, then look for the rest of the candidate's group.
  f.points.assign(f.size(), MapPointId::invalid());
  for (std::size_t i : inliers)
    f.points[pairs[i].keypoint] = pairs[i].point;
  f.cam_from_world = pose;
  matching::optimize_frame_pose(f, map);
  matching::drop_outliers(f);
  std::vector<KeyframeId> group{candidate};
  for (KeyframeId k : map.covisible(candidate, o.group_neighbours))
    group.push_back(k);
  v.inliers = guided_search(map, group, o, o.projection_radius_px, f);
  if (v.inliers < o.min_inliers) {
    v.rejection = "too few inliers after the guided search";
    return v;
  }
  v.corrected_cam_from_world = f.cam_from_world;
  v.matches = f.points;
  if (o.current_pose_hypothesis) {
    // The same search from the new keyframe's own pose (see LoopOptions).
    frame::Frame here = cur->frame;
    here.points.assign(here.size(), MapPointId::invalid());
    here.outlier.assign(here.size(), 0);
    // Wide first (the drift since the place was seen), then as narrow as the loop's own search
    // from the refined pose.
    guided_search(map, group, o, o.current_pose_radius_px, here);
    v.current_pose_inliers = guided_search(map, group, o, o.projection_radius_px, here);
    if (v.current_pose_inliers >= o.min_inliers) {
      const SE3 between = here.cam_from_world * v.corrected_cam_from_world.inverse();
      v.hypothesis_moved_m = between.translation().norm();
      v.inliers = v.current_pose_inliers;
      v.corrected_cam_from_world = here.cam_from_world;
      v.matches = here.points;
    }
  }
  plausibility(map, *cur, o, v);
  if (!v.accepted || !o.free_space_test || depth_camera == nullptr) return v;
  std::vector<KeyframeId> near_current{current};
  for (KeyframeId k : map.covisible(current, o.free_space_neighbours))
    near_current.push_back(k);
  const Stopwatch watch;
  v.free_space = free_space_against(map, near_current,
                                    v.corrected_cam_from_world.inverse() * cur->cam_from_world(),
                                    group, *depth_camera, o.free_space);
  v.free_space_ms = watch.elapsed_ms();
  if (v.free_space.compared() >= o.min_free_space_samples &&
      v.free_space.violation() > o.max_free_space_violation) {
    v.accepted = false;
    v.look_alike = true;
    v.rejection = "the depth disagrees (a look-alike place?)";
  }
  return v;
}

}  // namespace coloc::slam::loop
