#pragma once
// One RGB-D frame as tracking sees it: ORB features, the registered depth at each keypoint and
// the virtual right coordinate u_r = u - bf / d that turns an RGB-D observation into a
// stereo-like 3-dof measurement (ORB-SLAM2's RGB-D mode). Keypoints are bucketed in a grid over
// the undistorted image bounds so projection searches only look at nearby features.
//
// Frames: keypoint pixels are undistorted (ideal pinhole with fx fy cx cy); cam_from_world maps
// world points (metres) into the camera frame (x right, y down, z forward).
// A Frame is a plain value: owned by tracking, copied into a Keyframe when one is made. The
// geometry is shared, immutable, by every frame of a run.
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <vector>

#include "slam/bow/bow_vector.hpp"
#include "slam/core/camera.hpp"
#include "slam/core/ids.hpp"
#include "slam/core/se3.hpp"
#include "slam/features/orb_extractor.hpp"

namespace coloc::slam::frame {

// Intrinsics and the depth model shared by every frame of a run.
struct FrameGeometry {
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  double bf = 0.0;           // baseline * fx (pixels * metres) of the virtual stereo rig
  double close_depth = 0.0;  // metres: nearer keypoints are "close" (ThDepth * baseline)
  double min_depth = 0.1;    // metres: depth readings outside [min, max] count as invalid
  double max_depth = 10.0;
  double readout = 0.0;  // seconds, rolling-shutter readout of the colour camera (0 = global)
  // Undistorted image bounds (pixels) that the grid covers.
  double min_x = 0.0, max_x = 0.0, min_y = 0.0, max_y = 0.0;
  int grid_cols = 64;
  int grid_rows = 48;
  std::vector<float> scale_factors;  // per pyramid level: scale_factor^l
  std::vector<float> level_sigma2;   // per level: scale^2 (pixel variance of a measurement)
  double log_scale_factor = 0.0;

  // From a camera (its distortion sets the undistorted bounds) and the extractor's pyramid.
  static FrameGeometry make(const Camera& camera, double bf, double close_depth,
                            const std::vector<float>& scale_factors);
  // Throws coloc::Error naming the first invalid field.
  void check() const;
  Eigen::Vector2d project(const Eigen::Vector3d& p_cam) const {
    return {fx * p_cam.x() / p_cam.z() + cx, fy * p_cam.y() / p_cam.z() + cy};
  }
  bool in_bounds(const Eigen::Vector2d& uv) const {
    return uv.x() >= min_x && uv.x() < max_x && uv.y() >= min_y && uv.y() < max_y;
  }
  int levels() const { return static_cast<int>(scale_factors.size()); }
};

class Frame {
 public:
  Frame() = default;
  // `depth`: CV_32FC1 metres registered to the colour image (0 = invalid); may be empty (then
  // every keypoint is monocular).
  Frame(FrameId id, double timestamp, features::OrbFeatures features, const cv::Mat& depth,
        std::shared_ptr<const FrameGeometry> geometry);
  // A frame as a map file saved it (slam/mapdb), without an image: the features with the depth
  // (metres, <= 0 invalid) and virtual right coordinate (< 0 none) of each keypoint exactly as
  // they were computed, so nothing is re-derived from a depth image. The grid is rebuilt;
  // points start invalid and outlier flags 0, for the caller to fill. Throws coloc::Error when
  // depth or u_right does not have one value per keypoint, or geometry is null.
  Frame(FrameId id, double timestamp, features::OrbFeatures features, std::vector<float> depth,
        std::vector<float> u_right, std::shared_ptr<const FrameGeometry> geometry);

  FrameId id;
  double timestamp = 0.0;  // seconds
  features::OrbFeatures features;
  std::vector<float> depth;           // metres per keypoint, <= 0 when invalid
  std::vector<float> u_right;         // virtual right u per keypoint, < 0 when no depth
  std::vector<MapPointId> points;     // map point matched to each keypoint (invalid = none)
  std::vector<std::uint8_t> outlier;  // per keypoint, set by pose optimization
  bow::BowVector bow;
  bow::FeatureVector feature_vector;
  SE3 cam_from_world;
  bool has_pose = false;

  std::size_t size() const { return features.size(); }
  const FrameGeometry& geometry() const { return *geometry_; }
  // The shared geometry itself (null for a default-constructed frame): a map file stores one
  // camera row per distinct geometry and keyframes refer to it.
  const std::shared_ptr<const FrameGeometry>& geometry_ptr() const { return geometry_; }
  // The grid (row-major cells, grid_rows x grid_cols), derived from the keypoints: cell c holds
  // grid_keypoints()[grid_starts()[c] .. grid_starts()[c + 1]), ascending; keypoints outside
  // the bounds are in no cell. Read-only, for checks (a restored frame equals the saved one).
  const std::vector<std::uint32_t>& grid_starts() const { return grid_start_; }
  const std::vector<std::uint32_t>& grid_keypoints() const { return grid_keypoint_; }
  Eigen::Vector2d pixel(std::size_t i) const {
    return {features.keypoints[i].ux, features.keypoints[i].uy};
  }
  int level(std::size_t i) const { return features.keypoints[i].level; }
  bool has_depth(std::size_t i) const { return depth[i] > 0.0f; }
  bool is_close(std::size_t i) const {
    return depth[i] > 0.0f && depth[i] < geometry_->close_depth;
  }
  // World point of keypoint i from its depth (requires has_pose and has_depth(i)).
  Eigen::Vector3d unproject_world(std::size_t i) const;
  Eigen::Vector3d camera_centre() const { return cam_from_world.inverse().translation(); }
  // Keypoints within `radius` pixels of (x, y) with level in [min_level, max_level] (a negative
  // max_level means no upper limit).
  std::vector<std::size_t> features_in_area(double x, double y, double radius, int min_level = 0,
                                            int max_level = -1) const;
  std::size_t tracked_count() const;  // keypoints with a valid point that are not outliers
  // Drops what only a search in this frame's image reads: the per-keypoint depth and virtual
  // right coordinate, and the grid. For a keyframe that is only ever matched by BoW and
  // through its points (a map loaded for localization, mapdb::LoadOptions::keyframe_search):
  // ~24 kB a keyframe of 1,000 keypoints. has_depth, is_close, unproject_world and the
  // rolling-shutter compensation must not be called afterwards; features_in_area finds none.
  void drop_search_data();
  // Rolling-shutter compensation (slam/frame/rolling_shutter.hpp) with a readout time (seconds)
  // and the camera's angular velocity (rad/s, camera frame): moves the undistorted keypoints,
  // their virtual right coordinates and the grid, and records what it applied (shutter_*; with
  // readout 0 only the record, for a readout estimated later). Apply once per frame.
  void compensate_rolling_shutter(const Eigen::Vector3d& omega_cam, int image_rows, double readout);
  // Compensates the keypoints again for another readout time, with the recorded rate (a
  // readout estimated online has changed). Nothing moves without a recorded rate.
  void set_shutter_readout(double readout);
  // Compensates the keypoints again for another rate at the same readout.
  void set_shutter_rate(const Eigen::Vector3d& omega_cam);
  // How keypoint i's observation moves per second of readout change (optim::shutter_shifted).
  Eigen::Vector3d shutter_shear(std::size_t i) const;

  // The compensation applied: angular rate (rad/s, camera frame; zero = none), readout time
  // (seconds) and image rows. Not part of a saved map: a loaded keyframe has no rate.
  Eigen::Vector3d shutter_rate = Eigen::Vector3d::Zero();
  double shutter_readout = 0.0;
  int shutter_rows = 0;

 private:
  void assign_grid();
  void compensate(const Eigen::Vector3d& omega_cam, double readout);
  std::shared_ptr<const FrameGeometry> geometry_;  // shared by all frames of a run
  // The grid as compressed rows: 4 bytes per cell and per keypoint, ~18 kB for 1,500 keypoints.
  // A vector per cell took ~100 kB (3,072 vector headers, one allocation per non-empty cell),
  // more than the descriptors, in every keyframe of a map (a site map holds thousands).
  std::vector<std::uint32_t> grid_start_;     // grid_rows x grid_cols + 1 offsets
  std::vector<std::uint32_t> grid_keypoint_;  // keypoint indices, cell by cell
};

}  // namespace coloc::slam::frame
