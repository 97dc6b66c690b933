#pragma once
// A posed RGB-D recording fused into a coloured point cloud in its ground truth's frame (`coloc
// scan from-sequence`): any real recording with ground truth becomes a "scanned building" to
// register a map of it against. Every `every`-th frame whose time has a ground-truth pose
// (within `max_pose_dt`) is back-projected through the settings' camera and depth scale, and
// the points are averaged in a voxel grid as they come (memory follows the surface, not the
// number of frames).
//
// 7-Scenes: its colour and depth images are not registered (different cameras, no extrinsics
// given), so a depth pixel's colour is taken from the colour image at the same pixel: the
// geometry is exact to the depth camera, the colour is offset by a few pixels at edges.
#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <unordered_map>

#include "registration/render/scene.hpp"
#include "slam/core/camera.hpp"
#include "slam/core/trajectory.hpp"
#include "slam/dataset/sequence.hpp"

namespace coloc::registration::align {

struct SequenceCloudOptions {
  std::size_t every = 5;     // one frame in `every`
  double voxel_size = 0.01;  // metres: one point per voxel (mean position and colour)
  double min_depth = 0.2;    // metres: depth outside [min, max] is not used (sensor limits)
  double max_depth = 4.0;
  double max_pose_dt = 0.01;  // seconds between a frame and its ground-truth pose
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

struct SequenceCloudStats {
  std::size_t frames_used = 0, frames_without_pose = 0, frames_unreadable = 0;
  std::uint64_t depth_points = 0;  // back-projected before the voxel grid
};

// Points averaged in a voxel grid as they come (mean position and colour per voxel): how
// fuse_posed_frames builds its cloud, for other sources of posed depth too (a map's stored
// keyframe depth, markerless.hpp). Memory follows the surface, not the number of points added.
class VoxelFusion {
 public:
  explicit VoxelFusion(double voxel_size);  // metres, > 0
  void add(const Eigen::Vector3d& point, const std::array<std::uint8_t, 3>& rgb);
  std::uint64_t points_added() const { return added_; }
  render::PointCloud cloud() const;

 private:
  struct Voxel {  // running sums (double: millions of points per voxel stay exact enough)
    Eigen::Vector3d position = Eigen::Vector3d::Zero();
    std::array<double, 3> colour{};
    std::uint32_t points = 0;
  };
  double voxel_size_;
  std::unordered_map<std::uint64_t, Voxel> grid_;
  std::uint64_t added_ = 0;
};

// Throws coloc::Error naming the sequence when it has no ground truth or no frame was used.
// `progress` (may be empty) sees (frames done, frames).
render::PointCloud fuse_sequence(
    const dataset::Sequence& sequence, const Camera& camera,
    const SequenceCloudOptions& options = {}, SequenceCloudStats* stats = nullptr,
    const std::function<void(std::uint64_t, std::uint64_t)>& progress = {});

// The same with the poses given (world_from_cam by timestamp; a SLAM map's keyframes for its
// dense cloud): every `every`-th frame of the sequence that has one of `poses` within
// `max_pose_dt`.
render::PointCloud fuse_posed_frames(
    const dataset::Sequence& sequence, const Camera& camera, const Trajectory& poses,
    const SequenceCloudOptions& options, SequenceCloudStats* stats = nullptr,
    const std::function<void(std::uint64_t, std::uint64_t)>& progress = {});

// Writes `cloud` as PLY (float xyz, uchar rgb) or as E57 (one scan, xyz to 0.1 mm, rgb), by the
// extension of `path` (.ply or .e57); atomically. Throws coloc::Error naming the file.
void write_point_cloud(const std::filesystem::path& path, const render::PointCloud& cloud,
                       const std::string& description);

}  // namespace coloc::registration::align
