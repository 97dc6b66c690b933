#pragma once
// A seeded synthetic SLAM map for the map-database tests and `coloc bench mapdb` (COLMAP's
// habit: the generator lives in the library). Built through the Map's own editing API, so it
// has what a real run leaves behind: keyframes with ORB-like keypoints (random descriptors,
// pyramid levels, depth and virtual right coordinates), points observed by several keyframes,
// covisibility, a spanning tree, loop edges, markers, IMU measurements, and optionally depth
// images and erased keyframes. The geometry
// is meaningless (keypoints are random pixels); sizes and relations are what count.
//
// Keyframe k sits at x = 0.1 k metres in the world, looking along +z (cam_from_world).
#include <cstdint>
#include <functional>
#include <memory>

#include "slam/bow/vocabulary.hpp"
#include "slam/frame/frame.hpp"
#include "slam/map/map.hpp"

namespace coloc::slam::mapdb {

struct SyntheticMapOptions {
  std::uint64_t seed = 1;
  int keyframes = 50;
  int keypoints = 1000;           // per keyframe (ORB-SLAM's default n_features)
  int track_length = 6;           // keyframes observing each point
  double matched_fraction = 0.5;  // keypoints of a keyframe that hold a point
  double depth_fraction = 0.8;    // keypoints with a depth reading
  int marker_every = 10;          // every n-th keyframe sees two markers (0: none)
  int erase_every = 0;            // then every n-th keyframe is erased, as culling does (0: none)
  // Loop closures between an early and a late keyframe (both sides' Keyframe::loop_edges, as
  // loop closing adds them), made before erasing, so erased ones are handed to their parents.
  int loop_edges = 3;
  // Gravity windows and gyro links (Keyframe::gravity, gyro) as two recordings with an IMU
  // store them, the second starting halfway; every seventh keyframe has no gravity window.
  // Made before erasing, so the links across erased keyframes are chained.
  bool imu = true;
  // Depth images (Keyframe::depth) of the 640 x 480 frames downsampled by this factor, random
  // millimetres with a tenth of the pixels invalid, on every keyframe but each third one (maps
  // continued from an older file mix both). 0: none (`coloc bench mapdb` measures maps without).
  int depth_factor = 0;
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

// 640x480 pinhole, f = 525, bf = 40 (TUM-like), close depth 3 m, 8 levels of scale 1.2.
std::shared_ptr<const frame::FrameGeometry> synthetic_geometry();

// Deterministic for given options. With a vocabulary the keyframes get their BoW vectors (as
// tracking computes them); without, they stay empty. `progress` gets (keyframes built, total).
map::Map make_synthetic_map(const SyntheticMapOptions& options,
                            const std::shared_ptr<const frame::FrameGeometry>& geometry,
                            const bow::Vocabulary* vocabulary = nullptr,
                            const std::function<void(int, int)>& progress = {});

}  // namespace coloc::slam::mapdb
