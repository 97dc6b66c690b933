#include "registration/align/markerless.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "registration/align/transform.hpp"
#include "slam/core/error.hpp"
#include "slam/core/timing.hpp"
#include "slam/core/trajectory.hpp"

namespace coloc::registration::align {

namespace {

// The map's keyframes as a trajectory (world_from_cam), in time order.
Trajectory keyframe_trajectory(const slam::map::Map& map) {
  Trajectory keyframes;
  for (const auto& [id, kf] : map.keyframes())
    keyframes.push_back({kf.frame.timestamp, kf.cam_from_world().inverse()});
  std::sort(keyframes.begin(), keyframes.end(),
            [](const auto& a, const auto& b) { return a.timestamp < b.timestamp; });
  return keyframes;
}

}  // namespace

void DepthSampleOptions::check() const {
  if (stride_px < 1) throw Error("must be >= 1", {.field = "stride_px"});
  if (!(min_depth >= 0.0 && max_depth > min_depth && std::isfinite(max_depth)))
    throw Error("must satisfy 0 <= min_depth < max_depth", {.field = "max_depth"});
}

void MarkerlessOptions::check() const {
  global.check();
  map_cloud.check();
  scan_surface.check();
  depth_samples.check();
  surface_ba.check();
}

std::size_t keyframes_without_depth(const slam::map::Map& map) {
  std::size_t n = 0;
  for (const auto& [id, kf] : map.keyframes())
    n += kf.depth ? 0 : 1;
  return n;
}

void check_depth_source(const slam::map::Map& map, const dataset::Sequence* sequence) {
  if (sequence) return;
  // All or nothing: a map whose older keyframes lack depth (continued from a schema-3 file)
  // would be registered by part of itself and bent by part of its poses.
  const std::size_t missing = keyframes_without_depth(map);
  if (missing > 0)
    throw Error(std::to_string(missing) + " of the map's " + std::to_string(map.keyframe_count()) +
                    " keyframes store no depth image (a map saved before schema 4, or made "
                    "without depth): give the recording the map was built from",
                {.field = "--sequence"});
}

namespace {

// The dense cloud from the keyframes' stored depth: each valid small pixel back-projected at the
// full-resolution pixel it stands for, as fuse_posed_frames does with every pixel of a frame.
render::PointCloud stored_dense_cloud(const slam::map::Map& map, const Camera& camera,
                                      const SequenceCloudOptions& o, SequenceCloudStats* stats) {
  o.check();
  SequenceCloudStats s;
  VoxelFusion grid(o.voxel_size);
  // In time order (the sequence's order), so the cloud is the same whatever the hash order.
  std::vector<const slam::map::Keyframe*> keyframes;
  for (const auto& [id, kf] : map.keyframes())
    keyframes.push_back(&kf);
  std::sort(keyframes.begin(), keyframes.end(), [](const auto* a, const auto* b) {
    return a->frame.timestamp < b->frame.timestamp ||
           (a->frame.timestamp == b->frame.timestamp && a->id < b->id);
  });
  for (std::size_t k = 0; k < keyframes.size(); k += o.every) {
    const slam::map::Keyframe& kf = *keyframes[k];
    if (!kf.depth) {
      ++s.frames_unreadable;
      continue;
    }
    const slam::map::KeyframeDepth& d = *kf.depth;
    const SE3 world_from_cam = kf.cam_from_world().inverse();
    for (int v = 0; v < d.height; ++v) {
      for (int u = 0; u < d.width; ++u) {
        const double z = d.metres(u, v);
        if (!(z >= o.min_depth && z <= o.max_depth)) continue;
        grid.add(world_from_cam * backproject(camera, d.full_pixel(u, v), z), {128, 128, 128});
        ++s.depth_points;
      }
    }
    ++s.frames_used;
  }
  if (s.frames_used == 0)
    throw Error("no keyframe of the map stores a depth image (a map saved before schema 4?)",
                {.field = "keyframe_depth"});
  if (stats) *stats = s;
  return grid.cloud();
}

// keyframe_depth_samples() from the stored depth: the grid of stride_px in full-resolution
// pixels, taken at the stored pixels that stand for its positions.
KeyframeDepthSamples stored_depth_samples(const slam::map::Map& map, const Camera& camera,
                                          const DepthSampleOptions& o) {
  KeyframeDepthSamples out;
  for (const auto& [id, kf] : map.keyframes()) {
    if (!kf.depth) continue;
    const slam::map::KeyframeDepth& d = *kf.depth;
    const int step = std::max(1, o.stride_px / d.factor);
    const int first = (o.stride_px / 2) / d.factor;
    std::vector<Eigen::Vector3d>& points = out[id];
    for (int v = first; v < d.height; v += step) {
      for (int u = first; u < d.width; u += step) {
        const double z = d.metres(u, v);
        if (z >= o.min_depth && z <= o.max_depth)
          points.push_back(backproject(camera, d.full_pixel(u, v), z));
      }
    }
  }
  return out;
}

}  // namespace

render::PointCloud map_dense_cloud(const slam::map::Map& map, const dataset::Sequence* sequence,
                                   const Camera& camera, const SequenceCloudOptions& options,
                                   SequenceCloudStats* stats) {
  if (!sequence) return stored_dense_cloud(map, camera, options, stats);
  SequenceCloudOptions o = options;
  o.max_pose_dt = 1e-3;  // a keyframe is one of the sequence's frames
  return fuse_posed_frames(*sequence, camera, keyframe_trajectory(map), o, stats);
}

KeyframeDepthSamples keyframe_depth_samples(const slam::map::Map& map,
                                            const dataset::Sequence* sequence, const Camera& camera,
                                            const DepthSampleOptions& o) {
  o.check();
  if (!sequence) return stored_depth_samples(map, camera, o);
  const dataset::Sequence& recording = *sequence;
  Trajectory frames;
  for (std::size_t i = 0; i < recording.size(); ++i)
    frames.push_back({recording.timestamp(i), SE3()});
  std::vector<std::pair<KeyframeId, double>> keyframes;  // by time
  Trajectory times;
  for (const auto& [id, kf] : map.keyframes()) {
    keyframes.emplace_back(id, kf.frame.timestamp);
  }
  std::sort(keyframes.begin(), keyframes.end(),
            [](const auto& a, const auto& b) { return a.second < b.second; });
  for (const auto& [id, t] : keyframes)
    times.push_back({t, SE3()});
  KeyframeDepthSamples out;
  for (const auto& [kf, frame_index] : associate_by_time(times, frames, 1e-3)) {
    dataset::Frame frame;
    try {
      frame = recording.frame(frame_index);
    } catch (const Error& e) {
      spdlog::warn("keyframe at t={:.3f}: no depth samples: {}", keyframes[kf].second, e.what());
      continue;
    }
    std::vector<Eigen::Vector3d>& points = out[keyframes[kf].first];
    const int half = o.stride_px / 2;
    for (int v = half; v < frame.depth.rows; v += o.stride_px) {
      const float* depth = frame.depth.ptr<float>(v);
      for (int u = half; u < frame.depth.cols; u += o.stride_px) {
        const double d = depth[u];
        if (d >= o.min_depth && d <= o.max_depth) points.push_back(backproject(camera, {u, v}, d));
      }
    }
  }
  return out;
}

std::optional<Eigen::Vector3d> map_up_direction(const slam::map::Map& map, std::size_t min_windows,
                                                std::size_t* windows) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  std::size_t n = 0;
  for (const auto& [id, kf] : map.keyframes()) {
    if (!kf.gravity) continue;
    const Eigen::Vector3d up =
        kf.cam_from_world().so3().inverse() * kf.gravity->specific_force_cam -
        kf.gravity->accel_world;
    if (!(up.norm() > 1.0) || !up.allFinite()) continue;  // not a gravity reading (m/s^2)
    sum += up.normalized();
    ++n;
  }
  if (windows) *windows = n;
  if (n < min_windows || sum.norm() < 0.98 * static_cast<double>(n)) return std::nullopt;
  return sum.normalized();
}

MarkerlessResult register_map_markerless(slam::map::Map& map, const dataset::Sequence* sequence,
                                         const Camera& camera, const render::PointCloud& scan_cloud,
                                         const MarkerlessOptions& options,
                                         const std::optional<SE3>& initial) {
  options.check();
  check_depth_source(map, sequence);
  MarkerlessResult r;
  r.depth_source = sequence ? "sequence" : "map";
  Stopwatch watch;
  const render::PointCloud dense =
      map_dense_cloud(map, sequence, camera, options.map_cloud, &r.map_cloud);
  r.map_cloud_points = dense.points.size();
  if (options.map_gravity && !initial) r.up_slam = map_up_direction(map, 5, &r.gravity_windows);
  if (r.up_slam) {
    // Level the map's cloud (its up onto +z), search yaw and translation, undo the levelling.
    const SE3 level(
        SO3::from_matrix(Eigen::Quaterniond::FromTwoVectors(*r.up_slam, Eigen::Vector3d::UnitZ())
                             .toRotationMatrix()),
        Eigen::Vector3d::Zero());
    render::PointCloud levelled = dense;
    for (Eigen::Vector3f& p : levelled.points)
      p = (level * p.cast<double>()).cast<float>();
    GlobalRegistrationOptions g = options.global;
    g.gravity = true;
    r.global = register_clouds(levelled, scan_cloud, g);
    r.global.scan_from_map = r.global.scan_from_map * level;
  } else {
    r.global = register_clouds(dense, scan_cloud, options.global, initial);
  }
  r.scan_from_slam = Sim3(r.global.scan_from_map);
  transform_map(map, r.scan_from_slam);
  r.ms_rigid = watch.elapsed_ms();
  if (!options.surface) return r;

  watch.restart();
  const ScanSurface surface(scan_cloud, options.scan_surface);
  r.surface_points = surface.size();
  const KeyframeDepthSamples samples =
      keyframe_depth_samples(map, sequence, camera, options.depth_samples);
  r.surface = surface_bundle_adjustment(map, surface, camera, samples, options.surface_ba);
  r.ms_surface = watch.elapsed_ms();
  return r;
}

std::string markerless_json(const MarkerlessResult& r) {
  using Json = nlohmann::ordered_json;
  const auto finite_or_null = [](double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); };
  const GlobalRegistrationReport& g = r.global;
  Json transform = Json::array();
  const Eigen::Matrix4d m = r.scan_from_slam.to_se3().matrix();
  for (int row = 0; row < 4; ++row) {
    for (int col = 0; col < 4; ++col)
      transform.push_back(m(row, col));
  }
  Json j = {{"level", r.surface ? "surface" : "cloud"},
            {"scan_from_slam", transform},
            {"fitness", g.fitness},
            {"inlier_rmse_m", g.rmse},
            {"overlap", g.overlap},
            {"runner_up_fitness", g.runner_up},
            {"colour_correlation", finite_or_null(g.colour_correlation)},
            {"runner_up_colour_correlation", finite_or_null(g.runner_up_colour_correlation)},
            {"decided_by_colour", g.decided_by_colour},
            {"feature_matches", g.matches},
            {"from_initial", g.from_initial},
            {"levelled_by_gravity", r.up_slam.has_value()},
            {"gravity_windows", r.gravity_windows},
            {"map_cloud_points", r.map_cloud_points},
            {"keyframes_fused", r.map_cloud.frames_used},
            {"depth_source", r.depth_source},
            {"ms", g.ms},
            {"ms_rigid", r.ms_rigid}};
  if (r.surface) {
    j["surface"] = Json::parse(surface_ba_json(*r.surface));
    j["surface"]["scan_surface_points"] = r.surface_points;
    j["surface"]["ms"] = r.ms_surface;
  }
  return j.dump();
}

}  // namespace coloc::registration::align
