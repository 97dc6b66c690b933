#pragma once
// A SLAM map registered to a scan without markers (`coloc register` without --markers): the
// map's dense cloud, each keyframe's depth image from the recording the map was built from,
// placed at the keyframe's pose, is registered to the scan's points (global_registration.hpp),
// and the whole map is moved by the result. A rigid transform: the map's own drift stays (the
// marker levels bend the map onto the scan; without markers that is not done yet).
#include <optional>

#include "registration/align/global_registration.hpp"
#include "registration/align/sequence_cloud.hpp"
#include "slam/core/sim3.hpp"
#include "slam/map/map.hpp"

namespace coloc::registration::align {

struct MarkerlessOptions {
  GlobalRegistrationOptions global;
  SequenceCloudOptions map_cloud{.every = 1, .voxel_size = 0.02};
  void check() const;
};

struct MarkerlessResult {
  GlobalRegistrationReport global;
  SequenceCloudStats map_cloud;
  std::size_t map_cloud_points = 0;
  Sim3 scan_from_slam;
};

// The map's keyframes, fused from `sequence` (the recording that built the map) at their poses.
render::PointCloud map_dense_cloud(const slam::map::Map& map, const dataset::Sequence& sequence,
                                   const Camera& camera, const SequenceCloudOptions& options,
                                   SequenceCloudStats* stats = nullptr);

// Registers `map` in place onto `scan_cloud`. `initial` (scan_from_slam) skips the global
// search. Throws coloc::Error as register_clouds does (field "registration").
MarkerlessResult register_map_markerless(slam::map::Map& map, const dataset::Sequence& sequence,
                                         const Camera& camera, const render::PointCloud& scan_cloud,
                                         const MarkerlessOptions& options = {},
                                         const std::optional<SE3>& initial = std::nullopt);

}  // namespace coloc::registration::align
