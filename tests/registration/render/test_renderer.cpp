#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <opencv2/core.hpp>
#include <thread>

#include "registration/render/cloud_cells.hpp"
#include "registration/render/renderer.hpp"
#include "slam/core/error.hpp"

namespace coloc::registration::render {
namespace {

PinholeCamera small_camera() {
  PinholeCamera c;
  c.width = 160;
  c.height = 120;
  c.fx = 150.0;
  c.fy = 148.0;
  c.cx = 79.3;
  c.cy = 60.8;
  return c;
}

// A square quad with corners a, a+e1, a+e1+e2, a+e2, textured with `texture` (uv 0..1).
TexturedMesh quad(const Eigen::Vector3f& a, const Eigen::Vector3f& e1, const Eigen::Vector3f& e2,
                  const cv::Mat& texture) {
  TexturedMesh m;
  m.vertices = {a, a + e1, a + e1 + e2, a + e2};
  m.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  m.tints.assign(4, Eigen::Vector3f::Ones());
  m.textures = {texture};
  m.parts = {{0, {0, 1, 2, 0, 2, 3}}};
  return m;
}

cv::Mat checker(int n, int cells) {
  cv::Mat t(n, n, CV_8UC3);
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) {
      const bool on = ((r * cells / n) + (c * cells / n)) % 2 == 0;
      t.at<cv::Vec3b>(r, c) = on ? cv::Vec3b(230, 40, 40) : cv::Vec3b(20, 60, 220);
    }
  }
  return t;
}

// A slanted plane n.p = d seen from a camera at a general pose.
struct Plane {
  Eigen::Vector3d normal;
  double d;
};

SE3 test_pose() {
  // cam_from_world: a camera at (0.3, -0.2, -0.5) slightly rotated.
  const SE3 world_from_cam(SO3::exp(Eigen::Vector3d(0.05, -0.08, 0.03)),
                           Eigen::Vector3d(0.3, -0.2, -0.5));
  return world_from_cam.inverse();
}

// Largest difference between the rendered depth and the analytic depth of a slanted plane along
// each pixel's (distorted) ray.
double worst_slanted_plane_depth_error(const PinholeCamera& cam) {
  Renderer renderer;
  // Plane through (0,0,4) spanned by e1 = (1,0,0.4) and e2 = (0,1,0.2), large enough to fill
  // the view.
  const Eigen::Vector3f e1(1.0f, 0.0f, 0.4f), e2(0.0f, 1.0f, 0.2f);
  const Eigen::Vector3f a = Eigen::Vector3f(0, 0, 4) - 10.0f * e1 - 10.0f * e2;
  renderer.set_mesh(quad(a, 20.0f * e1, 20.0f * e2, checker(64, 8)));
  const Eigen::Vector3d n = e1.cast<double>().cross(e2.cast<double>()).normalized();
  const Plane plane{n, n.dot(Eigen::Vector3d(0, 0, 4))};

  const SE3 cam_from_world = test_pose();
  const SE3 world_from_cam = cam_from_world.inverse();
  const RenderResult r = renderer.render(cam, cam_from_world);
  EXPECT_EQ(r.depth.rows, cam.height);
  EXPECT_EQ(r.depth.cols, cam.width);
  double worst = 0.0;
  for (int v = 0; v < cam.height; ++v) {
    for (int u = 0; u < cam.width; ++u) {
      // Ray through the pixel centre, in the world frame.
      const Eigen::Vector2d xy = cam.undistort({(u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy});
      const Eigen::Vector3d ray_cam(xy.x(), xy.y(), 1.0);
      const Eigen::Vector3d o = world_from_cam.translation();
      const Eigen::Vector3d dir = world_from_cam.rotation() * ray_cam;
      const double t = (plane.d - plane.normal.dot(o)) / plane.normal.dot(dir);
      // ray_cam has z = 1, so t is the depth.
      const float depth = r.depth.at<float>(v, u);
      if (!(depth > 0.0f)) return std::numeric_limits<double>::infinity();
      worst = std::max(worst, std::abs(depth - t));
      const cv::Vec3f p = r.points.at<cv::Vec3f>(v, u);
      const Eigen::Vector3d expected = o + t * dir;
      worst = std::max(worst, (Eigen::Vector3d(p[0], p[1], p[2]) - expected).norm());
    }
  }
  return worst;
}

TEST(Renderer, DepthMatchesAnalyticSlantedPlane) {
  EXPECT_LT(worst_slanted_plane_depth_error(small_camera()), 2e-4) << "metres";
}

// The post-warp interpolates depth on the surface instead of taking the nearest ideal sample,
// which on this plane (about 8 mm of depth per pixel) was millimetres off.
TEST(Renderer, DistortedDepthAndPointsFollowTheTrueRay) {
  PinholeCamera cam = small_camera();
  cam.distortion = {-0.28, 0.08, 0.001, -0.0005, 0.0};
  EXPECT_LT(worst_slanted_plane_depth_error(cam), 2e-4) << "metres";
}

TEST(Renderer, RenderedPointsProjectBackToTheirPixel) {
  Renderer renderer;
  renderer.set_mesh(quad({-5, -5, 3}, {10, 0, 1}, {0, 10, -2}, checker(64, 8)));
  const PinholeCamera cam = small_camera();
  const SE3 cam_from_world = test_pose();
  const RenderResult r = renderer.render(cam, cam_from_world);
  int hits = 0;
  double worst = 0.0;
  for (int v = 0; v < cam.height; ++v) {
    for (int u = 0; u < cam.width; ++u) {
      const cv::Vec3f p = r.points.at<cv::Vec3f>(v, u);
      if (std::isnan(p[0])) continue;
      ++hits;
      const Eigen::Vector3d pc = cam_from_world * Eigen::Vector3d(p[0], p[1], p[2]);
      EXPECT_NEAR(pc.z(), r.depth.at<float>(v, u), 1e-5);
      worst = std::max(worst, (cam.project(pc) - Eigen::Vector2d(u, v)).norm());
    }
  }
  EXPECT_EQ(hits, cam.width * cam.height);
  EXPECT_LT(worst, 5e-3) << "pixels";
}

TEST(Renderer, DistortionPostWarpKeepsPointsOnTheirPixels) {
  Renderer renderer;
  renderer.set_mesh(quad({-5, -5, 3}, {10, 0, 1}, {0, 10, -2}, checker(64, 8)));
  PinholeCamera cam = small_camera();
  cam.distortion = {-0.28, 0.08, 0.001, -0.0005, 0.0};
  const SE3 cam_from_world = test_pose();
  const RenderResult r = renderer.render(cam, cam_from_world);
  ASSERT_EQ(r.colour.cols, cam.width);
  double worst = 0.0;
  for (int v = 0; v < cam.height; ++v) {
    for (int u = 0; u < cam.width; ++u) {
      const cv::Vec3f p = r.points.at<cv::Vec3f>(v, u);
      ASSERT_FALSE(std::isnan(p[0]));
      const Eigen::Vector3d pc = cam_from_world * Eigen::Vector3d(p[0], p[1], p[2]);
      worst = std::max(worst, (cam.project(pc) - Eigen::Vector2d(u, v)).norm());
    }
  }
  // Nearest ideal sample: within half a pixel diagonal, stretched by the distortion.
  EXPECT_LT(worst, 1.0) << "pixels";
}

TEST(Renderer, TextureOrientationFollowsUv) {
  // Texture: red top half, blue bottom half (in image rows); quad facing the camera at z = 2
  // with v growing downwards in the image.
  cv::Mat t(64, 64, CV_8UC3, cv::Scalar(255, 0, 0));
  t.rowRange(32, 64).setTo(cv::Scalar(0, 0, 255));
  Renderer renderer;
  renderer.set_mesh(quad({-4, -3, 2}, {8, 0, 0}, {0, 6, 0}, t));
  const PinholeCamera cam = small_camera();
  const RenderResult r = renderer.render(cam, SE3());
  // Camera y points down, so the top of the image sees y < 0: the texture's top rows.
  const cv::Vec3b top = r.colour.at<cv::Vec3b>(10, 80);
  const cv::Vec3b bottom = r.colour.at<cv::Vec3b>(110, 80);
  EXPECT_GT(top[0], 200);
  EXPECT_LT(top[2], 50);
  EXPECT_GT(bottom[2], 200);
  EXPECT_LT(bottom[0], 50);
}

TEST(Renderer, IsDeterministicAcrossCallsAndInstances) {
  const TexturedMesh m = quad({-5, -5, 3}, {10, 0, 1}, {0, 10, -2}, checker(256, 16));
  Renderer a;
  a.set_mesh(m);
  Renderer b(RenderOptions{.supersample = 1});
  b.set_mesh(m);
  const PinholeCamera cam = small_camera();
  const RenderResult r1 = a.render(cam, test_pose());
  const RenderResult r2 = a.render(cam, test_pose());
  const RenderResult r3 = b.render(cam, test_pose());
  for (const RenderResult* other : {&r2, &r3}) {
    EXPECT_EQ(cv::norm(r1.colour, other->colour, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(r1.depth, other->depth, cv::NORM_INF), 0.0);
  }
}

TEST(Renderer, SupersamplingKeepsDepthExactAndSmoothsColour) {
  const TexturedMesh m = quad({-5, -5, 3}, {10, 0, 1}, {0, 10, -2}, checker(256, 64));
  Renderer one;
  Renderer three(RenderOptions{.supersample = 3});
  one.set_mesh(m);
  three.set_mesh(m);
  const PinholeCamera cam = small_camera();
  const RenderResult a = one.render(cam, test_pose());
  const RenderResult b = three.render(cam, test_pose());
  ASSERT_EQ(b.colour.size(), a.colour.size());
  EXPECT_LT(cv::norm(a.depth, b.depth, cv::NORM_INF), 1e-5);
  EXPECT_THROW(Renderer(RenderOptions{.supersample = 2}), Error);
}

TEST(Renderer, PointCloudGivesExactPointsAndMatchesMeshDepth) {
  // Plane z = 3 + 0.2 x sampled every 1 cm, and the same plane as a mesh.
  PointCloud cloud;
  cloud.splat_size = 0.012f;
  for (int i = -230; i <= 230; ++i) {
    for (int j = -180; j <= 180; ++j) {
      const float x = i * 0.01f, y = j * 0.01f;
      cloud.points.emplace_back(x, y, 3.0f + 0.2f * x);
      cloud.colours.push_back(
          {static_cast<std::uint8_t>(i & 255), static_cast<std::uint8_t>(j & 255), 128});
    }
  }
  Renderer renderer;
  renderer.set_point_cloud(cloud);
  renderer.set_mesh(quad({-2, -2, 2.6f}, {4, 0, 0.8f}, {0, 4, 0}, checker(64, 8)));
  const PinholeCamera cam = small_camera();
  const SE3 pose(SO3::exp(Eigen::Vector3d(0.02, 0.03, 0.0)), Eigen::Vector3d(0.05, 0, 0));
  const RenderResult pts = renderer.render(cam, pose, Layer::kPoints);
  const RenderResult mesh = renderer.render(cam, pose, Layer::kMesh);
  int covered = 0;
  for (int v = 0; v < cam.height; ++v) {
    for (int u = 0; u < cam.width; ++u) {
      const int id = pts.index.at<int>(v, u);
      if (id < 0) continue;
      ++covered;
      const Eigen::Vector3f& p = cloud.points[static_cast<std::size_t>(id)];
      const cv::Vec3f q = pts.points.at<cv::Vec3f>(v, u);
      ASSERT_EQ(q[0], p.x());
      ASSERT_EQ(q[2], p.z());
      const Eigen::Vector3d pc = pose * p.cast<double>();
      EXPECT_NEAR(pts.depth.at<float>(v, u), pc.z(), 1e-5);
      // The splat centre lies within half a splat of the pixel.
      const double half = 0.5 * cam.fx * cloud.splat_size / pc.z() + 0.75;
      EXPECT_LT((cam.project(pc) - Eigen::Vector2d(u, v)).norm(), half * std::sqrt(2.0));
      // Same surface as the mesh: depth differs at most by the plane's slope over a splat.
      EXPECT_NEAR(pts.depth.at<float>(v, u), mesh.depth.at<float>(v, u), 0.006);
      EXPECT_EQ(mesh.index.at<int>(v, u), -1);
    }
  }
  // Splats close the surface: every pixel is covered.
  EXPECT_EQ(covered, cam.width * cam.height);
}

// The walls, floor and ceiling of an 8 x 6 x 3 m room sampled every 4 cm, coloured by position.
PointCloud room_cloud() {
  PointCloud cloud;
  cloud.splat_size = 0.05f;
  const auto add = [&](const Eigen::Vector3f& p) {
    cloud.points.push_back(p);
    cloud.colours.push_back({static_cast<std::uint8_t>(p.x() * 30.0f),
                             static_cast<std::uint8_t>(p.y() * 40.0f),
                             static_cast<std::uint8_t>(p.z() * 80.0f)});
    cloud.splat_sizes.push_back(0.04f + 0.002f * p.x());
  };
  for (float a = 0.0f; a <= 8.0f; a += 0.04f) {
    for (float b = 0.0f; b <= 6.0f; b += 0.04f) {
      add({a, b, 0.0f});
      add({a, b, 3.0f});
    }
    for (float z = 0.0f; z <= 3.0f; z += 0.04f) {
      add({a, 0.0f, z});
      add({a, 6.0f, z});
    }
  }
  for (float b = 0.0f; b <= 6.0f; b += 0.04f) {
    for (float z = 0.0f; z <= 3.0f; z += 0.04f) {
      add({0.0f, b, z});
      add({8.0f, b, z});
    }
  }
  return cloud;
}

TEST(Renderer, CullingByCellsDrawsTheSameImage) {
  const PointCloud cloud = room_cloud();
  Renderer all({.cull_cell = 0.0});
  Renderer culled;  // 1 m cells
  Renderer fine({.cull_cell = 0.3});
  for (Renderer* r : {&all, &culled, &fine})
    r->set_point_cloud(cloud);
  const PinholeCamera cam = small_camera();
  // Inside the room looking along each wall, into a corner, up and down, and one camera
  // outside looking in through the wall.
  const std::vector<SE3> world_from_cams = {
      SE3(SO3::exp({0.0, 1.2, 0.0}), Eigen::Vector3d(1.0, 3.0, 1.5)),
      SE3(SO3::exp({0.0, -2.0, 0.0}), Eigen::Vector3d(7.0, 1.0, 1.5)),
      SE3(SO3::exp({-1.4, 0.0, 0.0}), Eigen::Vector3d(4.0, 3.0, 1.0)),
      SE3(SO3::exp({1.5, 0.3, 0.0}), Eigen::Vector3d(4.0, 2.0, 2.0)),
      SE3(SO3::exp({0.0, 1.57, 0.0}), Eigen::Vector3d(-3.0, 3.0, 1.5))};
  for (std::size_t k = 0; k < world_from_cams.size(); ++k) {
    const SE3 cam_from_world = world_from_cams[k].inverse();
    const RenderResult a = all.render(cam, cam_from_world, Layer::kPoints);
    for (Renderer* r : {&culled, &fine}) {
      const RenderResult b = r->render(cam, cam_from_world, Layer::kPoints);
      // Cells change the drawing order, so where two splats lie at the same depth the other
      // may win (a float's last bit, a colour level); a splat culled wrongly would leave a
      // hole or the surface behind it, far off in depth.
      EXPECT_LE(cv::norm(a.depth, b.depth, cv::NORM_INF), 1e-5) << "camera " << k;
      EXPECT_LE(cv::norm(a.colour, b.colour, cv::NORM_INF), 2.0) << "camera " << k;
      EXPECT_EQ(cv::countNonZero(a.index >= 0), cv::countNonZero(b.index >= 0)) << "camera " << k;
      EXPECT_EQ(cv::countNonZero((a.index >= 0) != (b.index >= 0)), 0) << "camera " << k;
    }
  }
  // And the cells do cull: a camera facing one wall from near it draws a fraction of the room.
  const CloudCells cells = group_into_cells(cloud, 1.0f);
  std::size_t drawn = 0;
  for (const auto& range : visible_ranges(cells, cam, world_from_cams[0].inverse(), 0.05, 200.0,
                                          0.5 * cloud.max_splat_pixels + 1.0))
    drawn += range.second;
  EXPECT_GT(drawn, 0u);
  EXPECT_LT(drawn, cloud.points.size() / 2);
}

bool same_bytes(const cv::Mat& a, const cv::Mat& b) {
  return a.type() == b.type() && a.size() == b.size() && a.isContinuous() && b.isContinuous() &&
         std::memcmp(a.data, b.data, a.total() * a.elemSize()) == 0;
}

bool same_render(const RenderResult& a, const RenderResult& b) {
  return same_bytes(a.colour, b.colour) && same_bytes(a.depth, b.depth) &&
         same_bytes(a.points, b.points) && same_bytes(a.index, b.index);
}

TEST(Renderer, RenderersSharingOneCloudOnTwoThreadsDrawWhatOneDrawsAlone) {
  const PointCloud cloud = room_cloud();
  const PinholeCamera cam = small_camera();
  std::vector<SE3> cam_from_worlds;
  for (int k = 0; k < 8; ++k) {
    const double yaw = 0.8 * k;
    cam_from_worlds.push_back(SE3(SO3::exp({0.1 * (k % 3) - 0.1, yaw, 0.0}),
                                  Eigen::Vector3d(1.0 + 0.8 * k, 1.0 + 0.5 * k, 1.5))
                                  .inverse());
  }
  Renderer alone;
  alone.set_point_cloud(cloud);
  std::vector<RenderResult> expected;
  for (const SE3& pose : cam_from_worlds)
    expected.push_back(alone.render(cam, pose, Layer::kPoints));

  auto shared = std::make_shared<const SharedPointCloud>(cloud);
  EXPECT_EQ(shared->size(), cloud.points.size());
  // The vertex (20 B) and its upload position (4 B), once for every Renderer.
  EXPECT_LT(shared->bytes(), 25 * cloud.points.size());
  // Each thread draws every view three times, in its own order, so the two draw at once.
  constexpr int kRounds = 3;
  std::array<std::vector<RenderResult>, 2> got;
  std::array<std::thread, 2> threads;
  for (std::size_t t = 0; t < 2; ++t) {
    threads[t] = std::thread([&, t, mine = shared] {
      Renderer renderer({}, mine);
      for (int round = 0; round < kRounds; ++round) {
        for (std::size_t k = 0; k < cam_from_worlds.size(); ++k) {
          const std::size_t view = t == 0 ? k : cam_from_worlds.size() - 1 - k;
          got[t].push_back(renderer.render(cam, cam_from_worlds[view], Layer::kPoints));
        }
      }
    });
  }
  shared.reset();  // the Renderers keep the cloud alive
  for (std::thread& t : threads)
    t.join();
  for (std::size_t t = 0; t < 2; ++t) {
    ASSERT_EQ(got[t].size(), kRounds * cam_from_worlds.size());
    for (std::size_t i = 0; i < got[t].size(); ++i) {
      const std::size_t k = i % cam_from_worlds.size();
      const std::size_t view = t == 0 ? k : cam_from_worlds.size() - 1 - k;
      EXPECT_TRUE(same_render(got[t][i], expected[view])) << "thread " << t << " view " << view;
    }
  }
  // Not everything is empty: the views see the room.
  EXPECT_GT(cv::countNonZero(expected[0].index >= 0), cam.width * cam.height / 2);
}

TEST(Renderer, SharedCloudCanBeReplacedByOwnCloud) {
  const PointCloud cloud = room_cloud();
  PointCloud other = cloud;
  for (auto& c : other.colours)
    c = {200, 10, 10};
  Renderer renderer({}, std::make_shared<const SharedPointCloud>(cloud));
  const SE3 pose = SE3(SO3::exp({0.0, 1.2, 0.0}), Eigen::Vector3d(1.0, 3.0, 1.5)).inverse();
  const PinholeCamera cam = small_camera();
  const RenderResult before = renderer.render(cam, pose, Layer::kPoints);
  renderer.set_point_cloud(other);  // drops the shared cloud (its last holder)
  const RenderResult after = renderer.render(cam, pose, Layer::kPoints);
  EXPECT_TRUE(same_bytes(before.depth, after.depth));
  EXPECT_FALSE(same_bytes(before.colour, after.colour));
  renderer.clear_point_cloud();
  EXPECT_EQ(cv::countNonZero(renderer.render(cam, pose, Layer::kPoints).index >= 0), 0);
  EXPECT_THROW(Renderer({}, nullptr), Error);
}

TEST(Renderer, RejectsBadInput) {
  Renderer renderer;
  TexturedMesh bad = quad({0, 0, 1}, {1, 0, 0}, {0, 1, 0}, checker(8, 2));
  bad.parts[0].indices.push_back(7);
  EXPECT_THROW(renderer.set_mesh(bad), Error);
  EXPECT_THROW(renderer.render(PinholeCamera{}, SE3()), Error);
}

}  // namespace
}  // namespace coloc::registration::render
