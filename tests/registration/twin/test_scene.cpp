#include <gtest/gtest.h>

#include <opencv2/aruco.hpp>
#include <opencv2/imgproc.hpp>

#include "registration/render/renderer.hpp"
#include "registration/twin/generator.hpp"
#include "registration/twin/scene.hpp"
#include "registration/twin/textures.hpp"
#include "slam/core/error.hpp"

namespace coloc::registration::twin {
namespace {

SceneOptions small_room() {
  SceneOptions o;
  o.preset = Preset::kRoom;
  o.texture_size = 512;
  return o;
}

// world_from_cam of a camera at `eye` looking at `target` (image "down" = world -z).
SE3 look_at(const Eigen::Vector3d& eye, const Eigen::Vector3d& target) {
  const Eigen::Vector3d z = (target - eye).normalized();
  const Eigen::Vector3d x = (-Eigen::Vector3d::UnitZ()).cross(z).normalized();
  Eigen::Matrix3d r;
  r << x, z.cross(x), z;
  return SE3(SO3::from_matrix(r), eye);
}

TEST(TwinScene, SameSeedSameSceneOtherSeedOtherScene) {
  const TwinScene a = build_scene(small_room(), 5);
  const TwinScene b = build_scene(small_room(), 5);
  const TwinScene c = build_scene(small_room(), 6);
  ASSERT_EQ(a.mesh.vertices.size(), b.mesh.vertices.size());
  for (std::size_t i = 0; i < a.mesh.vertices.size(); ++i) {
    ASSERT_EQ(a.mesh.vertices[i], b.mesh.vertices[i]);
  }
  ASSERT_EQ(a.mesh.textures.size(), b.mesh.textures.size());
  for (std::size_t i = 0; i < a.mesh.textures.size(); ++i) {
    EXPECT_EQ(cv::norm(a.mesh.textures[i], b.mesh.textures[i], cv::NORM_INF), 0.0) << i;
  }
  EXPECT_GT(cv::norm(a.mesh.textures[0], c.mesh.textures[0], cv::NORM_L1), 0.0);
  ASSERT_EQ(a.markers.size(), b.markers.size());
  for (std::size_t i = 0; i < a.markers.size(); ++i) {
    EXPECT_EQ(a.markers[i].corners[0], b.markers[i].corners[0]);
  }
}

TEST(TwinScene, PresetsHaveMarkersStationsAndAClosedPath) {
  for (Preset p : {Preset::kRoom, Preset::kBuilding}) {
    SceneOptions o = small_room();
    o.preset = p;
    o.texture_size = 128;
    const TwinScene s = build_scene(o, 2);
    EXPECT_GE(s.markers.size(), 6u);
    EXPECT_GE(s.plan.stations.size(), 2u);
    EXPECT_FALSE(s.plan.furniture.empty());
    for (const auto& st : s.plan.stations)
      EXPECT_TRUE(s.plan.is_free(st.head<2>()));
    for (const auto& w : s.plan.path)
      EXPECT_TRUE(s.plan.is_free(w)) << w.transpose();
    for (const MarkerTruth& m : s.markers) {
      EXPECT_NEAR((m.corners[0] - m.corners[1]).norm(), o.marker_size, 1e-9);
      EXPECT_NEAR((m.corners[1] - m.corners[2]).norm(), o.marker_size, 1e-9);
      // Corners in the marker frame are OpenCV's (-s/2, s/2, 0), (s/2, s/2, 0), ...
      const Eigen::Vector3d tl = m.world_from_marker.inverse() * m.corners[0];
      EXPECT_NEAR(tl.x(), -o.marker_size / 2, 1e-9);
      EXPECT_NEAR(tl.y(), o.marker_size / 2, 1e-9);
    }
  }
  SceneOptions bad = small_room();
  bad.marker_size = -1;
  EXPECT_THROW(build_scene(bad, 1), Error);
}

// The paper's moved table: the sequence's scene has furniture where the scan's has none, and
// nothing else changed (same walls, markers and path).
TEST(TwinScene, MovedFurnitureMovesOnlyFurniture) {
  SceneOptions o;
  o.preset = Preset::kBuilding;
  o.texture_size = 128;
  const TwinScene before = build_scene(o, 3);
  o.moved_furniture = 3;
  const TwinScene after = build_scene(o, 3);
  EXPECT_EQ(after.moved_furniture, 3);
  ASSERT_EQ(after.plan.furniture.size(), before.plan.furniture.size());
  int moved = 0;
  for (std::size_t i = 0; i < before.plan.furniture.size(); ++i) {
    const Box& a = before.plan.furniture[i];
    const Box& b = after.plan.furniture[i];
    if ((a.min - b.min).norm() < 1e-9) continue;
    ++moved;
    EXPECT_NEAR((b.min - a.min).norm(), 0.8, 1e-9);
    EXPECT_NEAR(((b.max - b.min) - (a.max - a.min)).norm(), 0.0, 1e-9) << "same size";
    EXPECT_DOUBLE_EQ(a.min.z(), b.min.z());
  }
  EXPECT_EQ(moved, 3);
  EXPECT_EQ(after.plan.path, before.plan.path);
  ASSERT_EQ(after.markers.size(), before.markers.size());
  for (std::size_t i = 0; i < before.markers.size(); ++i)
    EXPECT_EQ(after.markers[i].corners, before.markers[i].corners);
}

TEST(TwinScene, PathOfBuildingPresetIsAtLeast40Metres) {
  SceneOptions o = small_room();
  o.preset = Preset::kBuilding;
  o.texture_size = 128;
  const TwinScene s = build_scene(o, 1);
  double length = 0.0;
  for (std::size_t i = 1; i < s.plan.path.size(); ++i) {
    length += (s.plan.path[i] - s.plan.path[i - 1]).norm();
  }
  EXPECT_GT(length, 40.0);
  // The walk ends where it started (a loop, for loop closure).
  EXPECT_LT((s.plan.path.front() - s.plan.path.back()).norm(), 3.0);
}

TEST(TwinScene, ArucoDetectionsMatchGroundTruthCorners) {
  const TwinScene scene = build_scene(small_room(), 3);
  render::Renderer renderer;
  renderer.set_mesh(scene.mesh);
  const PinholeCamera cam = GenerateOptions::default_camera(640, 480);
  const cv::Ptr<cv::aruco::Dictionary> dict = cv::aruco::getPredefinedDictionary(scene.dictionary);
  cv::Ptr<cv::aruco::DetectorParameters> params = cv::aruco::DetectorParameters::create();
  params->cornerRefinementMethod = cv::aruco::CORNER_REFINE_SUBPIX;
  int checked = 0;
  double worst = 0.0;
  for (const MarkerTruth& m : scene.markers) {
    const Eigen::Vector3d right = m.world_from_marker.rotation().col(0);
    const Eigen::Vector3d normal = m.world_from_marker.rotation().col(2);
    const Eigen::Vector3d centre = m.world_from_marker.translation();
    const SE3 world_from_cam = look_at(
        centre + 1.1 * normal + 0.3 * right + Eigen::Vector3d(0, 0, 0.1), centre + 0.05 * right);
    const SE3 cam_from_world = world_from_cam.inverse();
    const render::RenderResult r = renderer.render(cam, cam_from_world, render::Layer::kMesh);
    cv::Mat gray;
    cv::cvtColor(r.colour, gray, cv::COLOR_RGB2GRAY);
    std::vector<std::vector<cv::Point2f>> corners;
    std::vector<int> ids;
    cv::aruco::detectMarkers(gray, dict, corners, ids, params);
    bool found = false;
    for (std::size_t k = 0; k < ids.size(); ++k) {
      if (ids[k] != m.id) continue;
      found = true;
      for (std::size_t c = 0; c < 4; ++c) {
        const Eigen::Vector2d truth = cam.project(cam_from_world * m.corners[c]);
        const Eigen::Vector2d got(corners[k][c].x, corners[k][c].y);
        worst = std::max(worst, (truth - got).norm());
        EXPECT_LT((truth - got).norm(), 0.5) << "marker " << m.id << " corner " << c;
      }
      // Depth at the marker centre is its exact distance along the optical axis.
      const Eigen::Vector3d pc = cam_from_world * centre;
      const Eigen::Vector2d px = cam.project(pc);
      const float d = r.depth.at<float>(static_cast<int>(std::lround(px.y())),
                                        static_cast<int>(std::lround(px.x())));
      EXPECT_NEAR(d, pc.z(), 0.01);
    }
    EXPECT_TRUE(found) << "marker " << m.id << " not detected";
    checked += found;
  }
  EXPECT_GE(checked, 6);
  RecordProperty("worst_corner_error_px", std::to_string(worst));
}

TEST(TwinTextures, MarkerTextureDecodesToItsId) {
  const cv::Mat t = make_marker_texture(0, 17, 10, 1);
  EXPECT_EQ(t.cols, (4 + 2 + 2) * 10);
  cv::Mat gray, big;
  cv::cvtColor(t, gray, cv::COLOR_RGB2GRAY);
  cv::copyMakeBorder(gray, big, 40, 40, 40, 40, cv::BORDER_CONSTANT, cv::Scalar(255));
  std::vector<std::vector<cv::Point2f>> corners;
  std::vector<int> ids;
  cv::aruco::detectMarkers(big, cv::aruco::getPredefinedDictionary(0), corners, ids);
  ASSERT_EQ(ids.size(), 1u);
  EXPECT_EQ(ids[0], 17);
  EXPECT_THROW(make_marker_texture(0, 50, 10, 1), Error);
}

}  // namespace
}  // namespace coloc::registration::twin
