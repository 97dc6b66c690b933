#pragma once
// Shared by the map-database tests: a small synthetic map with everything a map can hold
// (erased keyframes, markers, BoW from the shipped vocabulary) and metadata that uses every
// field.
#include <filesystem>

#include "slam/mapdb/mapdb.hpp"
#include "slam/mapdb/synthetic_map.hpp"
#include "tests/slam/support/slam_test_support.hpp"

namespace coloc::slam::mapdb::test {

inline SyntheticMapOptions small_map_options(std::uint64_t seed = 1, int keyframes = 30) {
  SyntheticMapOptions o;
  o.seed = seed;
  o.keyframes = keyframes;
  o.keypoints = 300;
  o.marker_every = 4;
  o.erase_every = 5;
  o.depth_factor = 8;  // 80 x 60 depth images: every code path of 160 x 120, a quarter the bytes
  return o;
}

inline map::Map small_map(std::uint64_t seed = 1, int keyframes = 30) {
  return make_synthetic_map(small_map_options(seed, keyframes), synthetic_geometry(),
                            &test_support::vocabulary());
}

inline MapMetadata test_metadata() {
  MapMetadata m;
  m.vocabulary_checksum = vocabulary_checksum(test_support::vocabulary());
  m.vocabulary_words = test_support::vocabulary().word_count();
  m.settings = "%YAML:1.0\nCamera.fx: 525.0\n";
  m.frame_name = "scan";
  m.estimated_readout = 0.0171234567;  // seconds; must read back bit for bit
  m.frame_from_slam =
      Sim3(1.25, SO3::exp(Eigen::Vector3d(0.1, -0.2, 0.3)), Eigen::Vector3d(1.0 / 3.0, -2.0, 0.5));
  // The intrinsics of synthetic_geometry(), with distortion.
  m.camera = PinholeCamera{640, 480, 525.0, 525.0, 319.5, 239.5, {0.1, -0.2, 0.001, 0.002, 0.05}};
  return m;
}

}  // namespace coloc::slam::mapdb::test
