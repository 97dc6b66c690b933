// The map as the viewer's page reads it: counts, edges, poses and residuals of scene_of and
// its JSON, keyframe panels.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "slam/mapdb/synthetic_map.hpp"
#include "slam/view/scene.hpp"

namespace coloc::slam::view {
namespace {

map::Map test_map() {
  mapdb::SyntheticMapOptions o;
  o.keyframes = 12;
  o.keypoints = 200;
  o.marker_every = 3;
  o.loop_edges = 2;
  return mapdb::make_synthetic_map(o, mapdb::synthetic_geometry());
}

TEST(ViewScene, CopiesWhatThePageDraws) {
  const map::Map map = test_map();
  const MapScene scene = scene_of(map, {.min_covisibility = 15});
  ASSERT_EQ(scene.keyframes.size(), map.keyframe_count());
  EXPECT_EQ(scene.points.positions.size(), map.point_count());
  for (std::size_t i = 1; i < scene.keyframes.size(); ++i)
    EXPECT_LT(scene.keyframes[i - 1].id, scene.keyframes[i].id);
  std::size_t markers = 0, loops = 0;
  for (const auto& [id, kf] : map.keyframes()) {
    markers += kf.markers.size();
    loops += kf.loop_edges.size();
  }
  std::size_t scene_markers = 0;
  for (const SceneKeyframe& k : scene.keyframes) {
    const map::Keyframe& kf = *map.keyframe(KeyframeId(k.id));
    EXPECT_TRUE((k.world_from_cam.translation() - kf.camera_centre()).norm() < 1e-12);
    scene_markers += k.markers;
  }
  EXPECT_EQ(scene_markers, markers);
  EXPECT_EQ(scene.loop_edges.size() * 2, loops);  // each edge once
  for (const auto& [a, b, w] : scene.covisibility) {
    EXPECT_LT(a, b);
    EXPECT_GE(w, 15u);
    EXPECT_EQ(map.keyframe(KeyframeId(a))->covisibility.at(KeyframeId(b)), static_cast<int>(w));
  }
  // A higher bar keeps fewer edges.
  EXPECT_LT(scene_of(map, {.min_covisibility = 1000}).covisibility.size(),
            scene.covisibility.size() + 1);
  ASSERT_TRUE(scene.camera.has_value());
  EXPECT_EQ(scene.camera->width, 640);
}

TEST(ViewScene, ResidualIsZeroWhenPointsLieOnTheirRays) {
  map::Map map = test_map();
  const KeyframeId id = map.keyframes().begin()->first;
  const map::Keyframe& kf = *map.keyframe(id);
  const SE3 world_from_cam = kf.cam_from_world().inverse();
  const frame::FrameGeometry& g = kf.frame.geometry();
  for (std::size_t i = 0; i < kf.frame.points.size(); ++i) {
    map::MapPoint* p = kf.frame.points[i].valid() ? map.point(kf.frame.points[i]) : nullptr;
    if (p == nullptr) continue;
    const Eigen::Vector2d uv = kf.frame.pixel(i);
    p->position = world_from_cam *
                  (2.0 * Eigen::Vector3d((uv.x() - g.cx) / g.fx, (uv.y() - g.cy) / g.fy, 1.0));
  }
  const MapScene scene = scene_of(map);
  for (const SceneKeyframe& k : scene.keyframes) {
    if (k.id == id.value()) {
      EXPECT_GT(k.tracked, 0u);
      EXPECT_NEAR(k.residual_px, 0.0, 1e-6);
    } else if (k.tracked > 0) {
      EXPECT_GT(k.residual_px, 1.0);  // the synthetic keypoints are random pixels
    }
  }
  EXPECT_TRUE(scene_of(map, {.residuals = false}).keyframes.front().residual_px < 0.0);
}

TEST(ViewScene, MarkerResidualAgainstTheScanCorners) {
  const map::Map map = test_map();
  const PinholeCamera camera{640, 480, 525.0, 525.0, 319.5, 239.5, {}};
  MapScene scene = scene_of(map);
  // Scan corners on the rays of one keyframe's observation, 1.5 m away: that keyframe sees them
  // exactly where it observed them.
  const map::Keyframe* seer = nullptr;
  for (const auto& [id, kf] : map.keyframes())
    if (!kf.markers.empty() && (seer == nullptr || id.value() < seer->id.value())) seer = &kf;
  ASSERT_NE(seer, nullptr);
  const auto& obs = seer->markers.front();
  SceneMarker m{obs.id, {}};
  for (int c = 0; c < 4; ++c)
    m.corners[c] = seer->cam_from_world().inverse() * (1.5 * camera.unproject(obs.corners[c]));
  scene.scan_markers.push_back(m);
  add_marker_residuals(scene, map, camera);
  for (const SceneKeyframe& k : scene.keyframes) {
    if (k.id == seer->id.value()) {
      EXPECT_NEAR(k.marker_residual_px, 0.0, 1e-6);
    }
    if (k.markers == 0) {
      EXPECT_LT(k.marker_residual_px, 0.0);
    }
  }
}

TEST(ViewScene, JsonHasTheCountsAndPoses) {
  const map::Map map = test_map();
  const MapScene scene = scene_of(map);
  const auto j = nlohmann::json::parse(scene_json(scene, 7));
  EXPECT_EQ(j["version"], 7);
  EXPECT_EQ(j["frame"], "slam");
  ASSERT_EQ(j["keyframes"].size(), scene.keyframes.size());
  EXPECT_EQ(j["points"]["xyz"].size(), 3 * map.point_count());
  EXPECT_EQ(j["points"]["observations"].size(), map.point_count());
  EXPECT_EQ(j["loop_edges"].size(), scene.loop_edges.size());
  const auto& k = j["keyframes"][3];
  const Eigen::Vector3d centre = scene.keyframes[3].world_from_cam.translation();
  for (int a = 0; a < 3; ++a)
    EXPECT_NEAR(k["pose"][4 + a].get<double>(), centre[a], 1e-4);
}

TEST(ViewScene, KeyframePanel) {
  const map::Map map = test_map();
  EXPECT_FALSE(keyframe_json(map, 1u << 30).has_value());
  const map::Keyframe* with_markers = nullptr;
  for (const auto& [id, kf] : map.keyframes())
    if (!kf.markers.empty()) with_markers = &kf;
  ASSERT_NE(with_markers, nullptr);
  const auto j = nlohmann::json::parse(*keyframe_json(map, with_markers->id.value()));
  EXPECT_EQ(j["keypoints"].size(), 2 * with_markers->frame.size());
  EXPECT_EQ(j["tracked"].get<std::string>().size(), with_markers->frame.size());
  ASSERT_EQ(j["markers"].size(), with_markers->markers.size());
  EXPECT_EQ(j["markers"][0]["id"], with_markers->markers[0].id);
  EXPECT_NEAR(j["keypoints"][0].get<double>(), with_markers->frame.features.keypoints[0].x, 0.051);
}

}  // namespace
}  // namespace coloc::slam::view
