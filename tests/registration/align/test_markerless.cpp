// The markerless registration's depth from the map itself (registration/align/markerless.hpp):
// a map whose keyframes store their small depth images (map::KeyframeDepth) gives the dense
// cloud and the surface BA's depth samples the recording gives, within the downsampling, and
// without the recording; a map that lacks them is an error naming --sequence.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "registration/align/markerless.hpp"
#include "slam/core/error.hpp"
#include "slam/dataset/sequence.hpp"
#include "slam/map/keyframe_depth.hpp"
#include "slam/settings/settings.hpp"
#include "tests/testing/data.hpp"

namespace coloc::registration::align {
namespace {

namespace fs = std::filesystem;

// A map of TUM fr1/xyz: every 4th frame a keyframe at its ground-truth pose, storing its depth
// downsampled by 4 as tracking does.
struct RecordedMap {
  std::unique_ptr<dataset::Sequence> sequence;
  settings::Settings settings;
  slam::map::Map map;
};

RecordedMap recorded_map(const fs::path& dir) {
  RecordedMap r;
  r.sequence = dataset::open_sequence(dir);
  r.settings = settings::load_settings(testing::source_file("Examples/RGB-D/TUM1.yaml"));
  Trajectory frames;
  for (std::size_t i = 0; i < r.sequence->size(); i += 4)
    frames.push_back({r.sequence->timestamp(i), SE3()});
  for (const auto& [f, t] : associate_by_time(frames, r.sequence->ground_truth(), 0.01)) {
    const dataset::Frame frame = r.sequence->frame(4 * f);
    slam::map::Keyframe kf;
    kf.id = r.map.next_keyframe_id();
    kf.frame.timestamp = frame.timestamp;
    kf.frame.cam_from_world = r.sequence->ground_truth()[t].world_from_cam.inverse();
    kf.frame.has_pose = true;
    kf.depth = slam::map::downsample_depth(frame.depth.ptr<float>(), frame.depth.cols,
                                           frame.depth.rows, frame.depth.step1(), 4);
    r.map.add_keyframe(std::move(kf));
  }
  return r;
}

double percentile(std::vector<double> v, double q) {
  const auto k = static_cast<std::size_t>(q * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

// Distance from each point of `a` to the nearest point of `b` (searched within one cell of
// `cell` metres; farther counts as `cell`).
std::vector<double> nearest_distances(const render::PointCloud& a, const render::PointCloud& b,
                                      double cell) {
  const auto key = [&](const Eigen::Vector3d& p, int dx, int dy, int dz) {
    const auto c = [&](double x, int d) {
      return static_cast<std::int64_t>(std::floor(x / cell)) + d + (std::int64_t{1} << 20);
    };
    return (c(p.x(), dx) << 42) | (c(p.y(), dy) << 21) | c(p.z(), dz);
  };
  std::unordered_map<std::int64_t, std::vector<Eigen::Vector3d>> grid;
  for (const Eigen::Vector3f& p : b.points)
    grid[key(p.cast<double>(), 0, 0, 0)].push_back(p.cast<double>());
  std::vector<double> out;
  for (const Eigen::Vector3f& pf : a.points) {
    const Eigen::Vector3d p = pf.cast<double>();
    double best = cell;
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          auto it = grid.find(key(p, dx, dy, dz));
          if (it == grid.end()) continue;
          for (const Eigen::Vector3d& q : it->second)
            best = std::min(best, (p - q).norm());
        }
    out.push_back(best);
  }
  return out;
}

TEST(Markerless, StoredDepthGivesTheRecordingsDenseCloud) {
  COLOC_REQUIRE_DATA(dir, "tum_fr1_xyz_37f");
  const RecordedMap r = recorded_map(dir);
  ASSERT_GE(r.map.keyframe_count(), 8u);
  const Camera& camera = r.settings.camera;
  const SequenceCloudOptions o{.every = 1, .voxel_size = 0.02};
  SequenceCloudStats full_stats, stored_stats;
  const render::PointCloud full = map_dense_cloud(r.map, r.sequence.get(), camera, o, &full_stats);
  const render::PointCloud stored = map_dense_cloud(r.map, nullptr, camera, o, &stored_stats);
  EXPECT_EQ(stored_stats.frames_used, r.map.keyframe_count());
  EXPECT_EQ(full_stats.frames_used, r.map.keyframe_count());
  // A sixteenth of the pixels, averaged into the same 2 cm voxels: nearly as many voxels.
  EXPECT_GT(stored_stats.depth_points * 20, full_stats.depth_points);
  EXPECT_LT(stored_stats.depth_points * 12, full_stats.depth_points);
  EXPECT_GT(stored.points.size(), full.points.size() * 6 / 10);
  EXPECT_LE(stored.points.size(), full.points.size());
  // Each stored point near the recording's cloud: within a voxel (the downsampling moves a
  // pixel by at most 2 px, ~1 cm at 1.5 m, and the voxels' means differ by up to a voxel).
  const std::vector<double> d = nearest_distances(stored, full, 0.05);
  EXPECT_LT(percentile(d, 0.5), 0.01);
  EXPECT_LT(percentile(d, 0.9), 0.02);
}

TEST(Markerless, StoredDepthGivesTheRecordingsDepthSamples) {
  COLOC_REQUIRE_DATA(dir, "tum_fr1_xyz_37f");
  const RecordedMap r = recorded_map(dir);
  const Camera& camera = r.settings.camera;
  const KeyframeDepthSamples full = keyframe_depth_samples(r.map, r.sequence.get(), camera);
  const KeyframeDepthSamples stored = keyframe_depth_samples(r.map, nullptr, camera);
  ASSERT_EQ(stored.size(), r.map.keyframe_count());
  ASSERT_EQ(full.size(), r.map.keyframe_count());
  std::vector<double> depth_differences;
  for (const auto& [id, points] : stored) {
    // The same 16-pixel grid (shifted by 2 px): as many samples, give or take the invalid ones.
    const std::size_t n = full.at(id).size();
    EXPECT_NEAR(static_cast<double>(points.size()), static_cast<double>(n), 0.1 * n);
    const slam::map::Keyframe& kf = *r.map.keyframe(id);
    // Each sample lies on the recording's depth at the pixel it projects to.
    const std::size_t index = [&] {
      for (std::size_t i = 0; i < r.sequence->size(); ++i)
        if (std::abs(r.sequence->timestamp(i) - kf.frame.timestamp) < 1e-6) return i;
      return r.sequence->size();
    }();
    ASSERT_LT(index, r.sequence->size());
    const cv::Mat depth = r.sequence->frame(index).depth;
    for (const Eigen::Vector3d& p : points) {
      const Eigen::Vector2d px = project(camera, p);
      const int u = static_cast<int>(std::lround(px.x()));
      const int v = static_cast<int>(std::lround(px.y()));
      ASSERT_TRUE(u >= 0 && v >= 0 && u < depth.cols && v < depth.rows);
      const float z = depth.at<float>(v, u);
      if (z > 0.0f) depth_differences.push_back(std::abs(p.z() - z));
    }
  }
  ASSERT_GT(depth_differences.size(), 1000u);
  EXPECT_LT(percentile(depth_differences, 0.5), 0.01);
  EXPECT_LT(percentile(depth_differences, 0.8), 0.03);
}

TEST(Markerless, WithoutTheRecordingEveryKeyframeNeedsItsDepth) {
  COLOC_REQUIRE_DATA(dir, "tum_fr1_xyz_37f");
  RecordedMap r = recorded_map(dir);
  EXPECT_EQ(keyframes_without_depth(r.map), 0u);
  EXPECT_NO_THROW(check_depth_source(r.map, nullptr));
  r.map.keyframe(r.map.first_keyframe())->depth.reset();
  EXPECT_EQ(keyframes_without_depth(r.map), 1u);
  EXPECT_NO_THROW(check_depth_source(r.map, r.sequence.get()));
  try {
    register_map_markerless(r.map, nullptr, r.settings.camera, render::PointCloud{});
    ADD_FAILURE() << "registered without depth";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "--sequence");
    EXPECT_NE(e.message().find("1 of the map's"), std::string::npos) << e.message();
  }
  // The dense cloud leaves such keyframes out; with none left it is an error.
  SequenceCloudStats stats;
  map_dense_cloud(r.map, nullptr, r.settings.camera, {.every = 1, .voxel_size = 0.02}, &stats);
  EXPECT_EQ(stats.frames_unreadable, 1u);
  EXPECT_EQ(stats.frames_used, r.map.keyframe_count() - 1);
  r.map.for_each_keyframe([](slam::map::Keyframe& kf) { kf.depth.reset(); });
  EXPECT_THROW(map_dense_cloud(r.map, nullptr, r.settings.camera, {}), Error);
  EXPECT_TRUE(keyframe_depth_samples(r.map, nullptr, r.settings.camera).empty());
}

}  // namespace
}  // namespace coloc::registration::align
