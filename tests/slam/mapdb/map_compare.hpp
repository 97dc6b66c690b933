#pragma once
// Field-by-field comparison of two maps for the map-database tests: every stored and every
// derived field, floating-point values bit for bit (see same_value for REAL columns). Returns the
// first difference ("" if none).
#include <bit>
#include <cmath>
#include <cstring>
#include <sstream>
#include <string>

#include "slam/map/map.hpp"

namespace coloc::slam::mapdb::test {

inline bool same_bits(double a, double b) {
  return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
}
inline bool same_bits(float a, float b) {
  return std::bit_cast<std::uint32_t>(a) == std::bit_cast<std::uint32_t>(b);
}
template <int N>
bool same_bits(const Eigen::Matrix<double, N, 1>& a, const Eigen::Matrix<double, N, 1>& b) {
  for (int i = 0; i < N; ++i)
    if (!same_bits(a[i], b[i])) return false;
  return true;
}
// For values of REAL columns: bit for bit, except that SQLite keeps no sign of zero (it stores
// an integral REAL as an integer) and no NaN payload (a NaN is NULL). Blob values (poses,
// keypoints) are compared with same_bits.
inline bool same_value(double a, double b) {
  return same_bits(a, b) || (a == 0.0 && b == 0.0) || (std::isnan(a) && std::isnan(b));
}
template <int N>
bool same_value(const Eigen::Matrix<double, N, 1>& a, const Eigen::Matrix<double, N, 1>& b) {
  for (int i = 0; i < N; ++i)
    if (!same_value(a[i], b[i])) return false;
  return true;
}
inline bool same_bits(const SE3& a, const SE3& b) {
  return same_bits(Eigen::Vector4d(a.quaternion().coeffs()),
                   Eigen::Vector4d(b.quaternion().coeffs())) &&
         same_bits(a.translation(), b.translation());
}

inline std::string geometry_difference(const frame::FrameGeometry& a,
                                       const frame::FrameGeometry& b) {
  const double da[] = {
      a.fx,        a.fy,      a.cx,    a.cy,    a.bf,    a.close_depth, a.min_depth,
      a.max_depth, a.readout, a.min_x, a.max_x, a.min_y, a.max_y,       a.log_scale_factor};
  const double db[] = {
      b.fx,        b.fy,      b.cx,    b.cy,    b.bf,    b.close_depth, b.min_depth,
      b.max_depth, b.readout, b.min_x, b.max_x, b.min_y, b.max_y,       b.log_scale_factor};
  for (std::size_t i = 0; i < std::size(da); ++i)
    if (!same_value(da[i], db[i])) return "geometry field " + std::to_string(i);
  if (a.grid_cols != b.grid_cols || a.grid_rows != b.grid_rows) return "geometry grid";
  if (a.scale_factors != b.scale_factors || a.level_sigma2 != b.level_sigma2)
    return "geometry scales";
  return {};
}

inline std::string frame_difference(const frame::Frame& a, const frame::Frame& b) {
  if (a.id != b.id || !same_value(a.timestamp, b.timestamp) || a.has_pose != b.has_pose)
    return "id/timestamp/has_pose";
  if (!same_bits(a.cam_from_world, b.cam_from_world)) return "cam_from_world";
  if (a.size() != b.size()) return "keypoint count";
  if (a.features.image_width != b.features.image_width ||
      a.features.image_height != b.features.image_height)
    return "image size";
  // Both empty after frame::Frame::drop_search_data (a map loaded for localization).
  if (a.depth.size() != b.depth.size() || a.u_right.size() != b.u_right.size())
    return "depth/u_right count";
  for (std::size_t i = 0; i < a.size(); ++i) {
    const auto& p = a.features.keypoints[i];
    const auto& q = b.features.keypoints[i];
    if (!same_bits(p.x, q.x) || !same_bits(p.y, q.y) || !same_bits(p.ux, q.ux) ||
        !same_bits(p.uy, q.uy) || !same_bits(p.angle, q.angle) ||
        !same_bits(p.response, q.response) || p.level != q.level)
      return "keypoint " + std::to_string(i);
    if (i < a.depth.size() &&
        (!same_bits(a.depth[i], b.depth[i]) || !same_bits(a.u_right[i], b.u_right[i])))
      return "depth/u_right " + std::to_string(i);
  }
  if (a.features.descriptors != b.features.descriptors) return "descriptors";
  if (a.points != b.points) return "points";
  if (a.outlier != b.outlier) return "outlier";
  if (a.bow.size() != b.bow.size()) return "bow size";
  for (std::size_t i = 0; i < a.bow.size(); ++i) {
    if (a.bow.entries[i].word != b.bow.entries[i].word ||
        !same_bits(a.bow.entries[i].weight, b.bow.entries[i].weight))
      return "bow entry " + std::to_string(i);
  }
  if (a.feature_vector.level != b.feature_vector.level ||
      a.feature_vector.entries.size() != b.feature_vector.entries.size())
    return "feature vector";
  for (std::size_t i = 0; i < a.feature_vector.entries.size(); ++i) {
    if (a.feature_vector.entries[i].node != b.feature_vector.entries[i].node ||
        a.feature_vector.entries[i].features != b.feature_vector.entries[i].features)
      return "feature vector entry " + std::to_string(i);
  }
  if (const std::string g = geometry_difference(a.geometry(), b.geometry()); !g.empty()) return g;
  if (a.grid_starts() != b.grid_starts() || a.grid_keypoints() != b.grid_keypoints()) return "grid";
  return {};
}

inline std::string inertial_difference(const map::Keyframe& a, const map::Keyframe& b) {
  if (a.gravity.has_value() != b.gravity.has_value()) return "gravity window presence";
  if (a.gravity && (a.gravity->recording != b.gravity->recording ||
                    !same_value(a.gravity->specific_force_cam, b.gravity->specific_force_cam) ||
                    !same_value(a.gravity->accel_world, b.gravity->accel_world)))
    return "gravity window";
  if (a.gyro.has_value() != b.gyro.has_value()) return "gyro link presence";
  if (!a.gyro) return {};
  const map::GyroLink& p = *a.gyro;
  const map::GyroLink& q = *b.gyro;
  if (p.recording != q.recording || p.next != q.next || !same_value(p.dt, q.dt)) return "gyro link";
  if (!same_value(Eigen::Vector4d(p.cam_from_next.quaternion().coeffs()),
                  Eigen::Vector4d(q.cam_from_next.quaternion().coeffs())))
    return "gyro link rotation";
  for (int i = 0; i < 9; ++i)
    if (!same_bits(p.bias_jacobian(i), q.bias_jacobian(i))) return "gyro link bias Jacobian";
  return {};
}

inline std::string keyframe_difference(const map::Keyframe& a, const map::Keyframe& b) {
  if (a.parent != b.parent) return "parent";
  if (a.children != b.children) return "children";
  if (a.covisibility != b.covisibility) return "covisibility";
  if (a.covisible_ordered != b.covisible_ordered) return "covisible_ordered";
  if (a.loop_edges != b.loop_edges) return "loop_edges";
  if (!same_value(a.marker_size, b.marker_size)) return "marker_size";
  if (const std::string d = inertial_difference(a, b); !d.empty()) return d;
  if (a.depth.has_value() != b.depth.has_value()) return "depth image presence";
  if (a.depth && !(*a.depth == *b.depth)) return "depth image";
  if (a.markers.size() != b.markers.size()) return "marker count";
  for (std::size_t i = 0; i < a.markers.size(); ++i) {
    const auto& p = a.markers[i];
    const auto& q = b.markers[i];
    if (p.id != q.id || p.image_width != q.image_width || p.image_height != q.image_height)
      return "marker " + std::to_string(i);
    for (std::size_t c = 0; c < 4; ++c)
      if (!same_value(p.corners[c], q.corners[c])) return "marker corner " + std::to_string(i);
  }
  return frame_difference(a.frame, b.frame);
}

inline std::string point_difference(const map::MapPoint& a, const map::MapPoint& b) {
  if (!same_value(a.position, b.position) || !same_value(a.normal, b.normal)) return "position";
  if (a.descriptor != b.descriptor) return "descriptor";
  if (!same_value(a.min_distance, b.min_distance) || !same_value(a.max_distance, b.max_distance))
    return "distances";
  if (a.reference != b.reference || a.first_keyframe != b.first_keyframe) return "keyframes";
  if (a.observations != b.observations) return "observations";
  if (a.visible != b.visible || a.found != b.found) return "visible/found";
  return {};
}

// "" when the maps are identical; otherwise what differs first.
inline std::string map_difference(const map::Map& a, const map::Map& b) {
  if (a.keyframe_count() != b.keyframe_count() || a.point_count() != b.point_count())
    return "counts " + std::to_string(a.keyframe_count()) + "/" +
           std::to_string(b.keyframe_count()) + " keyframes";
  const map::MapBookkeeping ba = a.bookkeeping(), bb = b.bookkeeping();
  if (ba.first_keyframe != bb.first_keyframe || ba.next_keyframe_id != bb.next_keyframe_id ||
      ba.next_point_id != bb.next_point_id)
    return "bookkeeping";
  if (ba.erased.size() != bb.erased.size()) return "erased count";
  for (const auto& [id, e] : ba.erased) {
    auto it = bb.erased.find(id);
    if (it == bb.erased.end() || it->second.parent != e.parent ||
        !same_bits(it->second.cam_from_parent, e.cam_from_parent))
      return "erased keyframe " + std::to_string(id.value());
  }
  for (const auto& [id, kf] : a.keyframes()) {
    const map::Keyframe* other = b.keyframe(id);
    if (!other) return "keyframe " + std::to_string(id.value()) + " missing";
    if (const std::string d = keyframe_difference(kf, *other); !d.empty())
      return "keyframe " + std::to_string(id.value()) + ": " + d;
  }
  for (const auto& [id, p] : a.points()) {
    const map::MapPoint* other = b.point(id);
    if (!other) return "point " + std::to_string(id.value()) + " missing";
    if (const std::string d = point_difference(p, *other); !d.empty())
      return "point " + std::to_string(id.value()) + ": " + d;
  }
  return {};
}

}  // namespace coloc::slam::mapdb::test
