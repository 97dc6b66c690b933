// The point-cloud refinement (Michiels et al. 2024, section 4.5) on a small rendered scan: a
// textured room corner as a coloured point cloud; the "camera image" of a keyframe is the scan
// rendered at its true pose, its stored pose is perturbed, and matching its features against
// the scan rendered at the perturbed pose must give the true pose back. Failure cases give named
// outcomes and errors.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <random>

#include "e57io/synthetic.hpp"
#include "registration/align/refine.hpp"
#include "registration/align/register.hpp"
#include "registration/align/scan_cloud.hpp"
#include "registration/align/scan_match.hpp"
#include "registration/align/scan_outliers.hpp"
#include "registration/render/renderer.hpp"
#include "slam/core/error.hpp"

namespace coloc::registration::align {
namespace {

namespace features = slam::features;

PinholeCamera test_camera() {
  PinholeCamera c;
  c.width = 640;
  c.height = 480;
  c.fx = c.fy = 525.0;
  c.cx = 319.5;
  c.cy = 239.5;
  return c;
}

// A procedural texture with corners at several scales (rectangles and discs of random grey on
// fine noise), 1 pixel = 4 mm.
cv::Mat texture(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  cv::Mat t(1000, 1500, CV_8UC1);
  cv::randu(t, 90, 160);
  cv::GaussianBlur(t, t, cv::Size(3, 3), 0.8);
  std::uniform_int_distribution<int> x(0, 1499), y(0, 999), s(8, 90), g(0, 255);
  for (int i = 0; i < 700; ++i) {
    const cv::Point p(x(rng), y(rng));
    if (i % 3 == 0) {
      cv::circle(t, p, s(rng) / 2, cv::Scalar(g(rng)), cv::FILLED);
    } else {
      cv::rectangle(t, cv::Rect(p.x, p.y, s(rng), s(rng)), cv::Scalar(g(rng)), cv::FILLED);
    }
  }
  return t;
}

// Points every 5 mm on a plane through `origin` spanned by u, v (metres), coloured by the texture.
void add_plane(render::PointCloud& cloud, const cv::Mat& tex, const Eigen::Vector3d& origin,
               const Eigen::Vector3d& u, const Eigen::Vector3d& v, double width, double height) {
  const double step = 0.005;
  for (double a = 0.0; a < width; a += step) {
    for (double b = 0.0; b < height; b += step) {
      const int px = static_cast<int>(a / 0.004) % tex.cols;
      const int py = static_cast<int>(b / 0.004) % tex.rows;
      const std::uint8_t grey = tex.at<std::uint8_t>(py, px);
      cloud.points.push_back((origin + a * u + b * v).cast<float>());
      cloud.colours.push_back({grey, grey, grey});
    }
  }
}

// A room corner seen from the origin looking along +z: a back wall at z = 4, a side wall at
// x = -2 and a floor at y = 1.4 (camera frame conventions: y down).
render::PointCloud room() {
  render::PointCloud cloud;
  add_plane(cloud, texture(1), {-2.0, -1.2, 4.0}, Eigen::Vector3d::UnitX(),
            Eigen::Vector3d::UnitY(), 5.0, 2.6);
  add_plane(cloud, texture(2), {-2.0, -1.2, 0.5}, Eigen::Vector3d::UnitZ(),
            Eigen::Vector3d::UnitY(), 3.5, 2.6);
  add_plane(cloud, texture(3), {-2.0, 1.4, 0.5}, Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitZ(),
            5.0, 3.5);
  ScanCloudOptions o;
  o.voxel_size = 0.005;
  return voxel_downsample(cloud, o);
}

// The 5 cm / 1 degree perturbation of the test.
SE3 perturbed(const SE3& cam_from_world) {
  const SE3 delta(
      SO3::from_axis_angle(Eigen::Vector3d(1, 2, 3).normalized(), std::numbers::pi / 180.0),
      Eigen::Vector3d(0.03, -0.03, 0.0283));  // 5.0 cm
  return delta * cam_from_world;
}

std::shared_ptr<const slam::frame::FrameGeometry> geometry_of(const PinholeCamera& c) {
  std::vector<float> scales;
  for (int l = 0; l < 8; ++l)
    scales.push_back(static_cast<float>(std::pow(1.2, l)));
  return std::make_shared<slam::frame::FrameGeometry>(
      slam::frame::FrameGeometry::make(c, 40.0, 3.0, scales));
}

// A map of keyframes whose features come from the scan rendered at `truth` and whose stored
// pose is perturbed.
slam::map::Map keyframes_map(const render::PointCloud& cloud, const std::vector<SE3>& truth) {
  const PinholeCamera c = test_camera();
  render::Renderer renderer;
  renderer.set_point_cloud(cloud);
  features::OrbExtractor extractor;
  const auto g = geometry_of(c);
  slam::map::Map map;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    cv::Mat grey;
    cv::cvtColor(renderer.render(c, truth[i], render::Layer::kPoints).colour, grey,
                 cv::COLOR_RGB2GRAY);
    features::OrbFeatures f = extractor.extract(grey);
    const std::size_t n = f.size();
    slam::map::Keyframe kf;
    kf.id = map.next_keyframe_id();
    kf.frame = slam::frame::Frame(FrameId(i), 0.5 * static_cast<double>(i), std::move(f),
                                  std::vector<float>(n, -1.0f), std::vector<float>(n, -1.0f), g);
    kf.frame.points.assign(n, MapPointId());
    kf.frame.cam_from_world = perturbed(truth[i]);
    kf.frame.has_pose = true;
    map.add_keyframe(std::move(kf));
  }
  return map;
}

const render::PointCloud& shared_room() {
  static const render::PointCloud cloud = room();  // built once for the whole test binary
  return cloud;
}

TEST(Refine, RecoversAKeyframePerturbedBy5cmAnd1Degree) {
  const SE3 truth(SO3::exp(Eigen::Vector3d(0.05, -0.25, 0.02)), Eigen::Vector3d(0.2, 0.1, 0.3));
  const SE3 second(SO3::exp(Eigen::Vector3d(-0.05, 0.2, 0.0)), Eigen::Vector3d(-0.3, 0.0, 0.4));
  slam::map::Map map = keyframes_map(shared_room(), {truth, second});
  RefineOptions o;
  o.threads = 2;  // one renderer (GL context) per thread
  const std::vector<KeyframeRefinement> r = match_keyframes(map, shared_room(), test_camera(), o);
  ASSERT_EQ(r.size(), 2u);
  const SE3 truths[2] = {truth, second};
  for (std::size_t i = 0; i < 2; ++i) {
    SCOPED_TRACE(i);
    EXPECT_TRUE(r[i].accepted) << r[i].reason() << " matches " << r[i].matches << " inliers "
                               << r[i].inliers;
    ASSERT_TRUE(r[i].has_pose);
    EXPECT_NEAR(r[i].correction_m, 0.05, 0.01);
    EXPECT_NEAR(r[i].correction_deg, 1.0, 0.1);
    EXPECT_LT(pose_distance_m(r[i].pnp, truths[i]), 0.005);
    EXPECT_LT(pose_angle_deg(r[i].pnp, truths[i]), 0.1);
    EXPECT_GT(r[i].median_offset_px, 3.0);  // the rendering at the perturbed pose was off
    EXPECT_LT(r[i].rms_reprojection_px, 1.5);
  }
  // The same on one thread: the result does not depend on the thread count.
  o.threads = 1;
  const std::vector<KeyframeRefinement> one = match_keyframes(map, shared_room(), test_camera(), o);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(one[i].inliers, r[i].inliers);
    EXPECT_EQ(one[i].pnp.translation(), r[i].pnp.translation());
  }
}

TEST(Refine, WeakOrImpossibleMatchesAreNamedAndNotAccepted) {
  const SE3 truth(SO3::exp(Eigen::Vector3d(0.05, -0.25, 0.02)), Eigen::Vector3d(0.2, 0.1, 0.3));
  // Keyframe 0 looks away from the room (nothing rendered); keyframe 1's features are from the
  // room but its descriptors are scrambled (nothing matches); keyframe 2 is moved 50 cm
  // (implausible for a marker-registered map).
  slam::map::Map map = keyframes_map(shared_room(), {truth, truth, truth});
  std::vector<KeyframeId> ids;
  for (const auto& [id, kf] : map.keyframes())
    ids.push_back(id);
  std::sort(ids.begin(), ids.end());
  map.keyframe(ids[0])->frame.cam_from_world =
      SE3(SO3::exp(Eigen::Vector3d(0.0, std::numbers::pi, 0.0)), Eigen::Vector3d::Zero());
  for (auto& d : map.keyframe(ids[1])->frame.features.descriptors)
    d = {d[0] ^ 0x5555555555555555ULL, ~d[1], d[2] ^ 0xF0F0F0F0F0F0F0F0ULL, ~d[3]};
  RefineOptions o;
  o.max_correction_m = 0.02;  // keyframe 2 moves 5 cm: implausible under this bound
  const std::vector<KeyframeRefinement> r = match_keyframes(map, shared_room(), test_camera(), o);
  EXPECT_EQ(r[0].outcome, MatchOutcome::kTooFewRenderedFeatures);
  EXPECT_EQ(r[1].outcome, MatchOutcome::kTooFewMatches);
  EXPECT_EQ(r[2].reason(), "implausible");
  for (const KeyframeRefinement& k : r)
    EXPECT_FALSE(k.accepted);
}

// A walk of 5 m along a wall and back, both ways looking at it, then the same walk turned
// round: 1 m spacing keeps a keyframe a metre along each heading, and none of the walk back.
TEST(Refine, SpacingKeepsAKeyframeAMetreApartPerHeading) {
  slam::map::Map map;
  const auto add = [&map](double x, double yaw) {
    slam::map::Keyframe kf;
    kf.id = map.next_keyframe_id();
    const SE3 world_from_cam(SO3::exp(Eigen::Vector3d(0.0, yaw, 0.0)), Eigen::Vector3d(x, 0, 0));
    kf.frame.cam_from_world = world_from_cam.inverse();
    kf.frame.has_pose = true;
    return map.add_keyframe(std::move(kf)).id;
  };
  std::vector<KeyframeId> expected;
  for (int i = 0; i < 20; ++i) {
    const KeyframeId id = add(0.25 * i, 0.0);
    if (i % 4 == 0) expected.push_back(id);  // x = 0, 1, 2, 3, 4
  }
  for (int i = 19; i >= 0; --i)
    add(0.25 * i + 0.1, 0.05);  // the way back, the same heading within 3 deg: covered
  for (int i = 0; i < 20; ++i) {
    const KeyframeId id = add(0.25 * i, std::numbers::pi);
    if (i % 4 == 0) expected.push_back(id);
  }
  RefineOptions o;
  EXPECT_EQ(spaced_keyframes(map, o).size(), 60u);  // spacing 0: every keyframe
  o.keyframe_spacing_m = 1.0;
  EXPECT_EQ(spaced_keyframes(map, o), expected);
  o.keyframe_spacing_m = -1.0;
  try {
    o.check();
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "keyframe_spacing_m");
  }
}

TEST(Refine, NamedErrors) {
  slam::map::Map map = keyframes_map(shared_room(), {SE3()});
  RefineOptions o;
  o.match.min_inliers = 3;
  try {
    o.check();
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "min_inliers");
  }
  o = {};
  o.threads = 0;
  EXPECT_THROW(o.check(), Error);
  try {
    match_keyframes(map, render::PointCloud{}, test_camera(), {});
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "cloud");
  }
  try {
    load_scan_cloud("/nonexistent/scan.e57");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().file, "/nonexistent/scan.e57");
  }
  EXPECT_THROW(parse_level("dense"), Error);
  EXPECT_EQ(parse_level("pointcloud"), Level::kPointcloud);
}

TEST(ScanCloud, VoxelGridAveragesEachVoxel) {
  render::PointCloud c;
  c.points = {{0.001f, 0.001f, 0.001f}, {0.003f, 0.003f, 0.003f}, {0.5f, 0.5f, 0.5f}};
  c.colours = {{0, 0, 0}, {100, 200, 50}, {7, 7, 7}};
  ScanCloudOptions o;
  o.voxel_size = 0.01;
  const render::PointCloud d = voxel_downsample(c, o);
  ASSERT_EQ(d.points.size(), 2u);
  EXPECT_NEAR(d.points[0].x(), 0.002f, 1e-6f);
  EXPECT_EQ(d.colours[0][1], 100);
  EXPECT_FLOAT_EQ(d.splat_size, static_cast<float>(0.01 * o.splat_factor));
  o.voxel_size = -1.0;
  EXPECT_THROW(voxel_downsample(c, o), Error);
}

// A wall sampled every 1 cm near the scanner and every 4 cm far from it, plus stray returns in
// the air: the strays go, both parts of the wall stay (a global density threshold would take
// the far, sparse part too).
TEST(ScanCloud, StrayPointsAreRemovedAtEveryDensity) {
  render::PointCloud c;
  c.splat_size = 0.016f;
  const auto add = [&](const Eigen::Vector3f& p, float side) {
    c.points.push_back(p);
    c.colours.push_back({90, 90, 90});
    c.splat_sizes.push_back(side);
  };
  for (int i = 0; i < 50; ++i)
    for (int j = 0; j < 50; ++j)
      add({0.01f * i, 0.01f * j, 2.0f}, 0.016f);
  for (int i = 0; i < 30; ++i)
    for (int j = 0; j < 30; ++j)
      add({1.0f + 0.04f * i, 0.04f * j, 2.0f}, 0.06f);
  const std::size_t wall = c.points.size();
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<float> air(0.3f, 1.7f);
  for (int k = 0; k < 40; ++k)
    add({air(rng), air(rng), air(rng)}, 0.03f);
  EXPECT_EQ(remove_stray_points(c), 40u);
  ASSERT_EQ(c.points.size(), wall);
  for (const Eigen::Vector3f& p : c.points)
    EXPECT_FLOAT_EQ(p.z(), 2.0f);
  EXPECT_EQ(c.splat_sizes.size(), wall);
  EXPECT_EQ(remove_stray_points(c, {.min_neighbours = 0}), 0u);
  EXPECT_THROW(remove_stray_points(c, {.radius_factor = 0.0}), Error);
}

TEST(ScanCloud, ReadsAnE57FileWithColourAndRangeSplats) {
  const std::filesystem::path file =
      std::filesystem::path(::testing::TempDir()) / "scan_cloud_test.e57";
  e57::write_synthetic_scan(file, 20000);
  ScanCloudOptions o;
  o.voxel_size = 0.0;  // keep every point
  ScanCloudStats stats;
  std::uint64_t last = 0;
  const render::PointCloud c =
      load_scan_cloud(file, o, &stats, [&](std::uint64_t done, std::uint64_t) { last = done; });
  EXPECT_EQ(stats.scans, 1u);
  EXPECT_EQ(stats.points_read, 20000u);
  EXPECT_EQ(last, 20000u);
  EXPECT_TRUE(stats.colour);
  EXPECT_EQ(c.points.size(), 20000u);
  ASSERT_EQ(c.splat_sizes.size(), c.points.size());
  for (float v : c.splat_sizes)
    EXPECT_GE(v, c.splat_size);
  o.voxel_size = 0.01;  // the synthetic grid is 1 mm: fewer points after the voxel grid
  EXPECT_LT(load_scan_cloud(file, o).points.size(), c.points.size());
  std::filesystem::remove(file);
}

}  // namespace
}  // namespace coloc::registration::align
