// A real recording fused into a cloud (registration/align/sequence_cloud.hpp), TUM fr1/xyz with
// its motion-capture poses: the cloud seen from a frame that was NOT fused lands on that frame's
// own depth (the geometry is the ground truth's), and the cloud survives its files (PLY, E57)
// as every scan reader of ours reads them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "registration/align/point_file.hpp"
#include "registration/align/scan_cloud.hpp"
#include "registration/align/sequence_cloud.hpp"
#include "slam/core/error.hpp"
#include "slam/dataset/sequence.hpp"
#include "slam/settings/settings.hpp"
#include "tests/testing/data.hpp"

namespace coloc::registration::align {
namespace {

namespace fs = std::filesystem;

TEST(SequenceCloud, FusedCloudLandsOnTheDepthOfAFrameItDidNotUse) {
  COLOC_REQUIRE_DATA(dir, "tum_fr1_xyz_37f");
  const auto sequence = dataset::open_sequence(dir);
  const settings::Settings settings =
      settings::load_settings(testing::source_file("Examples/RGB-D/TUM1.yaml"));
  SequenceCloudOptions o;
  o.every = 4;  // frames 0, 4, 8, ...: frame 2 is not fused
  SequenceCloudStats stats;
  const render::PointCloud cloud = fuse_sequence(*sequence, settings.camera, o, &stats);
  EXPECT_EQ(stats.frames_used, (sequence->size() + 3) / 4);
  EXPECT_GT(cloud.points.size(), 50000u);

  // Frame 2 at its ground-truth pose: each cloud point that projects onto valid depth.
  const dataset::Frame frame = sequence->frame(2);
  Trajectory at{{frame.timestamp, SE3()}};
  const auto match = associate_by_time(at, sequence->ground_truth(), 0.01);
  ASSERT_EQ(match.size(), 1u);
  const SE3 cam_from_world = sequence->ground_truth()[match[0].second].world_from_cam.inverse();
  std::vector<double> differences;
  for (const Eigen::Vector3f& p : cloud.points) {
    const Eigen::Vector3d c = cam_from_world * p.cast<double>();
    if (c.z() < 0.3) continue;
    const Eigen::Vector2d px = project(settings.camera, c);
    const int u = static_cast<int>(std::lround(px.x())), v = static_cast<int>(std::lround(px.y()));
    if (u < 0 || v < 0 || u >= frame.depth.cols || v >= frame.depth.rows) continue;
    const float d = frame.depth.at<float>(v, u);
    if (d <= 0.0f) continue;
    differences.push_back(std::abs(c.z() - d));
  }
  ASSERT_GT(differences.size(), 10000u);
  std::nth_element(differences.begin(), differences.begin() + differences.size() / 2,
                   differences.end());
  // Kinect depth noise and mocap error at ~1.5 m: a median of about a centimetre. A wrong
  // frame, scale or pose convention gives decimetres.
  EXPECT_LT(differences[differences.size() / 2], 0.02);
}

TEST(SequenceCloud, WrittenCloudsReadBackThroughTheScanReaders) {
  render::PointCloud cloud;
  for (int i = 0; i < 100; ++i) {
    cloud.points.emplace_back(0.01f * i, 1.0f, -0.5f * i);
    cloud.colours.push_back({static_cast<std::uint8_t>(i), 20, 30});
  }
  const fs::path dir = fs::path(::testing::TempDir());
  ScanCloudOptions keep;
  keep.voxel_size = 0.0;
  keep.stray.min_neighbours = 0;
  for (const char* name : {"cloud.ply", "cloud.e57"}) {
    SCOPED_TRACE(name);
    write_point_cloud(dir / name, cloud, "test");
    const render::PointCloud back = load_scan_cloud(dir / name, keep);
    ASSERT_EQ(back.points.size(), cloud.points.size());
    for (std::size_t i = 0; i < cloud.points.size(); ++i) {
      // E57 keeps 0.1 mm, PLY the floats. The order is not promised: each point is found by
      // its colour (a red of its own).
      const auto it = std::find(back.colours.begin(), back.colours.end(), cloud.colours[i]);
      ASSERT_NE(it, back.colours.end());
      const auto& q = back.points[static_cast<std::size_t>(it - back.colours.begin())];
      EXPECT_LT((q - cloud.points[i]).norm(), 2e-4f);
    }
  }
  EXPECT_THROW(write_point_cloud(dir / "cloud.xyz", cloud, "test"), Error);
}

}  // namespace
}  // namespace coloc::registration::align
