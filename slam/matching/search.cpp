#include "slam/matching/search.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "slam/bow/matcher.hpp"

namespace coloc::slam::matching {

std::vector<std::size_t> rotation_outliers(const std::vector<float>& angle_change) {
  constexpr int kBins = 30;
  std::array<std::vector<std::size_t>, kBins> hist;
  for (std::size_t i = 0; i < angle_change.size(); ++i) {
    double a = std::fmod(static_cast<double>(angle_change[i]), 2.0 * std::numbers::pi);
    if (a < 0.0) a += 2.0 * std::numbers::pi;
    int bin = static_cast<int>(a / (2.0 * std::numbers::pi) * kBins);
    hist[static_cast<std::size_t>(std::clamp(bin, 0, kBins - 1))].push_back(i);
  }
  std::array<int, 3> top{-1, -1, -1};
  auto size_of = [&](int b) {
    return b < 0 ? 0 : static_cast<int>(hist[static_cast<std::size_t>(b)].size());
  };
  for (int b = 0; b < kBins; ++b) {
    const int s = size_of(b);
    if (s > size_of(top[0])) {
      top = {b, top[0], top[1]};
    } else if (s > size_of(top[1])) {
      top = {top[0], b, top[1]};
    } else if (s > size_of(top[2])) {
      top[2] = b;
    }
  }
  // Second and third bins only count when they hold a tenth of the first (ORB-SLAM).
  if (size_of(top[1]) < 0.1 * size_of(top[0])) top[1] = top[2] = -1;
  if (size_of(top[2]) < 0.1 * size_of(top[0])) top[2] = -1;
  std::vector<std::size_t> drop;
  for (int b = 0; b < kBins; ++b) {
    if (b == top[0] || b == top[1] || b == top[2]) continue;
    for (std::size_t i : hist[static_cast<std::size_t>(b)])
      drop.push_back(i);
  }
  return drop;
}

namespace {

// Applies the rotation filter to tentative matches (frame keypoint indices and angle changes).
int commit_matches(frame::Frame& frame, const std::vector<std::size_t>& keypoints,
                   const std::vector<MapPointId>& ids, const std::vector<float>& angles) {
  std::vector<std::uint8_t> keep(keypoints.size(), 1);
  for (std::size_t i : rotation_outliers(angles))
    keep[i] = 0;
  int n = 0;
  for (std::size_t i = 0; i < keypoints.size(); ++i) {
    if (!keep[i]) continue;
    frame.points[keypoints[i]] = ids[i];
    frame.outlier[keypoints[i]] = 0;
    ++n;
  }
  return n;
}

}  // namespace

int search_from_last_frame(frame::Frame& current, const frame::Frame& last, const map::Map& map,
                           double radius_px) {
  const auto& g = current.geometry();
  const SE3 current_from_last = current.cam_from_world * last.cam_from_world.inverse();
  // Camera motion along its axis decides which levels can see a point again (ORB-SLAM).
  const double tz = current_from_last.inverse().translation().z();
  const double baseline = g.bf / g.fx;
  const bool forward = tz > baseline, backward = -tz > baseline;
  std::vector<int> best_dist(current.size(), 256);
  std::vector<std::size_t> kps;
  std::vector<MapPointId> ids;
  std::vector<float> angles;
  for (std::size_t i = 0; i < last.size(); ++i) {
    if (!last.points[i].valid() || last.outlier[i]) continue;
    const map::MapPoint* p = map.point(last.points[i]);
    if (!p) continue;
    const Eigen::Vector3d pc = current.cam_from_world * p->position;
    if (pc.z() <= 0.0) continue;
    const Eigen::Vector2d uv = g.project(pc);
    if (!g.in_bounds(uv)) continue;
    const int level = last.level(i);
    const double r = radius_px * g.scale_factors[static_cast<std::size_t>(level)];
    std::vector<std::size_t> cand =
        forward    ? current.features_in_area(uv.x(), uv.y(), r, level)
        : backward ? current.features_in_area(uv.x(), uv.y(), r, 0, level)
                   : current.features_in_area(uv.x(), uv.y(), r, std::max(0, level - 1), level + 1);
    int best = 256;
    std::size_t best_idx = 0;
    const double ur_pred = uv.x() - g.bf / pc.z();
    for (std::size_t j : cand) {
      if (current.points[j].valid()) continue;
      if (current.u_right[j] >= 0.0f && std::abs(ur_pred - current.u_right[j]) > r) continue;
      const int d = features::hamming_distance(p->descriptor, current.features.descriptors[j]);
      if (d < best) {
        best = d;
        best_idx = j;
      }
    }
    if (best <= kDescriptorHigh && best < best_dist[best_idx]) {
      best_dist[best_idx] = best;
      kps.push_back(best_idx);
      ids.push_back(p->id);
      angles.push_back(last.features.keypoints[i].angle -
                       current.features.keypoints[best_idx].angle);
    }
  }
  // A keypoint claimed twice keeps its best (the later, better claim overwrote best_dist).
  std::vector<std::size_t> k2;
  std::vector<MapPointId> i2;
  std::vector<float> a2;
  std::vector<std::uint8_t> taken(current.size(), 0);
  for (std::size_t m = kps.size(); m-- > 0;) {
    if (taken[kps[m]]) continue;
    taken[kps[m]] = 1;
    k2.push_back(kps[m]);
    i2.push_back(ids[m]);
    a2.push_back(angles[m]);
  }
  return commit_matches(current, k2, i2, a2);
}

int search_local_points(frame::Frame& frame, const std::vector<MapPointId>& candidates,
                        const map::Map& map, double th, std::vector<MapPointId>* visible) {
  const auto& g = frame.geometry();
  const Eigen::Vector3d centre = frame.camera_centre();
  int n = 0;
  for (MapPointId id : candidates) {
    const map::MapPoint* p = map.point(id);
    if (!p) continue;
    const Eigen::Vector3d pc = frame.cam_from_world * p->position;
    if (pc.z() <= 0.0) continue;
    const Eigen::Vector2d uv = g.project(pc);
    if (!g.in_bounds(uv)) continue;
    const Eigen::Vector3d ray = p->position - centre;
    const double dist = ray.norm();
    if (dist < 0.8 * p->min_distance || dist > 1.2 * p->max_distance) continue;
    const double view_cos = ray.dot(p->normal) / dist;
    if (view_cos < 0.5) continue;
    if (visible) visible->push_back(id);
    const int level = p->predict_level(dist, g);
    const double r =
        th * (view_cos > 0.998 ? 2.5 : 4.0) * g.scale_factors[static_cast<std::size_t>(level)];
    const double ur_pred = uv.x() - g.bf / pc.z();
    int best = 256, second = 256, best_level = -1, second_level = -1;
    std::size_t best_idx = 0;
    for (std::size_t j : frame.features_in_area(uv.x(), uv.y(), r, std::max(0, level - 1), level)) {
      if (frame.points[j].valid() && !frame.outlier[j]) continue;
      if (frame.u_right[j] >= 0.0f && std::abs(ur_pred - frame.u_right[j]) > r) continue;
      const int d = features::hamming_distance(p->descriptor, frame.features.descriptors[j]);
      if (d < best) {
        second = best;
        second_level = best_level;
        best = d;
        best_level = frame.level(j);
        best_idx = j;
      } else if (d < second) {
        second = d;
        second_level = frame.level(j);
      }
    }
    if (best > kDescriptorHigh) continue;
    if (best_level == second_level && best > 0.8 * second) continue;
    frame.points[best_idx] = id;
    frame.outlier[best_idx] = 0;
    ++n;
  }
  return n;
}

int search_keyframe_points(frame::Frame& frame, const map::Keyframe& keyframe, const map::Map& map,
                           double radius_px, int max_distance) {
  const auto& g = frame.geometry();
  const Eigen::Vector3d centre = frame.camera_centre();
  std::vector<std::size_t> kps;
  std::vector<MapPointId> ids;
  std::vector<float> angles;
  std::vector<std::uint8_t> already(frame.size(), 0);
  std::vector<MapPointId> matched(frame.points);
  for (std::size_t i = 0; i < keyframe.frame.size(); ++i) {
    const MapPointId id = keyframe.frame.points[i];
    if (!id.valid() || std::find(matched.begin(), matched.end(), id) != matched.end()) continue;
    const map::MapPoint* p = map.point(id);
    if (!p) continue;
    const Eigen::Vector3d pc = frame.cam_from_world * p->position;
    if (pc.z() <= 0.0) continue;
    const Eigen::Vector2d uv = g.project(pc);
    if (!g.in_bounds(uv)) continue;
    const double dist = (p->position - centre).norm();
    if (dist < 0.8 * p->min_distance || dist > 1.2 * p->max_distance) continue;
    const int level = p->predict_level(dist, g);
    const double r = radius_px * g.scale_factors[static_cast<std::size_t>(level)];
    int best = 256;
    std::size_t best_idx = 0;
    for (std::size_t j :
         frame.features_in_area(uv.x(), uv.y(), r, std::max(0, level - 1), level + 1)) {
      if (frame.points[j].valid() || already[j]) continue;
      const int d = features::hamming_distance(p->descriptor, frame.features.descriptors[j]);
      if (d < best) {
        best = d;
        best_idx = j;
      }
    }
    if (best > max_distance) continue;
    already[best_idx] = 1;
    kps.push_back(best_idx);
    ids.push_back(id);
    angles.push_back(keyframe.frame.features.keypoints[i].angle -
                     frame.features.keypoints[best_idx].angle);
  }
  return commit_matches(frame, kps, ids, angles);
}

int search_by_bow(const map::Keyframe& keyframe, frame::Frame& frame, const map::Map& map) {
  bow::BowMatchOptions options;
  options.max_distance = kDescriptorLow;
  options.ratio = 0.7;
  const auto matches = bow::match_by_bow(keyframe.frame.features, keyframe.frame.feature_vector,
                                         frame.features, frame.feature_vector, options);
  int n = 0;
  for (const auto& m : matches) {
    const MapPointId id = keyframe.frame.points[m.index_a];
    if (!id.valid() || !map.point(id)) continue;
    frame.points[m.index_b] = id;
    frame.outlier[m.index_b] = 0;
    ++n;
  }
  return n;
}

}  // namespace coloc::slam::matching
