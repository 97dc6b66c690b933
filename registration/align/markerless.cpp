#include "registration/align/markerless.hpp"

#include "registration/align/transform.hpp"

namespace coloc::registration::align {

void MarkerlessOptions::check() const {
  global.check();
  map_cloud.check();
}

render::PointCloud map_dense_cloud(const slam::map::Map& map, const dataset::Sequence& sequence,
                                   const Camera& camera, const SequenceCloudOptions& options,
                                   SequenceCloudStats* stats) {
  Trajectory keyframes;
  for (const auto& [id, kf] : map.keyframes())
    keyframes.push_back({kf.frame.timestamp, kf.cam_from_world().inverse()});
  std::sort(keyframes.begin(), keyframes.end(),
            [](const auto& a, const auto& b) { return a.timestamp < b.timestamp; });
  SequenceCloudOptions o = options;
  o.max_pose_dt = 1e-3;  // a keyframe is one of the sequence's frames
  return fuse_posed_frames(sequence, camera, keyframes, o, stats);
}

MarkerlessResult register_map_markerless(slam::map::Map& map, const dataset::Sequence& sequence,
                                         const Camera& camera, const render::PointCloud& scan_cloud,
                                         const MarkerlessOptions& options,
                                         const std::optional<SE3>& initial) {
  options.check();
  MarkerlessResult r;
  const render::PointCloud dense =
      map_dense_cloud(map, sequence, camera, options.map_cloud, &r.map_cloud);
  r.map_cloud_points = dense.points.size();
  r.global = register_clouds(dense, scan_cloud, options.global, initial);
  r.scan_from_slam = Sim3(r.global.scan_from_map);
  transform_map(map, r.scan_from_slam);
  return r;
}

}  // namespace coloc::registration::align
