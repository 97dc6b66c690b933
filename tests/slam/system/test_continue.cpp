// Continuing a saved map (coloc map --load, ORB-SLAM3's System.LoadAtlasFromFile): the first
// half of a walk mapped and saved, the map loaded into a new System, the second half
// relocalized into it and mapped on: one map in one frame of reference, as accurate as mapping
// the walk in one go. And a recording of somewhere else adds nothing to the map.
#include <gtest/gtest.h>

#include <filesystem>

#include "slam/eval/trajectory_error.hpp"
#include "slam/mapdb/mapdb.hpp"
#include "slam/synthetic/synthetic_scene.hpp"
#include "slam/system/system.hpp"
#include "tests/slam/support/slam_test_support.hpp"
#include "tests/testing/data.hpp"

namespace coloc::slam::system {
namespace {

using synthetic::SyntheticRgbdScene;
using synthetic::SyntheticSceneOptions;
using test_support::vocabulary;

constexpr int kFrames = 60, kHalf = 30;

SyntheticRgbdScene walk(std::uint64_t seed = 7) {
  SyntheticSceneOptions o;
  o.frames = kFrames;
  o.seed = seed;
  return SyntheticRgbdScene(o);
}

SystemOptions sequential() {
  SystemOptions options;
  options.tracking.wait_for_sink = true;
  // Every keyframe the frames ask for: this small room is covered by the first half's few
  // keyframes at the default pace, and the second half must have views to add.
  options.tracking.min_frames_between_keyframes = 0;
  options.detect_markers = false;
  return options;
}

Trajectory truth_of(const SyntheticRgbdScene& scene) {
  Trajectory t;
  for (int i = 0; i < scene.size(); ++i)
    t.push_back({scene.frame(i).timestamp, scene.world_from_cam(i)});
  return t;
}

// The truth in the map's frame: SLAM's world is the first camera.
Trajectory truth_in_first_camera(const SyntheticRgbdScene& scene) {
  Trajectory t;
  const SE3 first_from_world = scene.world_from_cam(0).inverse();
  for (int i = 0; i < scene.size(); ++i)
    t.push_back({scene.frame(i).timestamp, first_from_world * scene.world_from_cam(i)});
  return t;
}

// Tracks frames [first, last); returns how many were tracked.
int track(System& slam, const SyntheticRgbdScene& scene, int first, int last) {
  int tracked = 0;
  for (int i = first; i < last; ++i) {
    const auto f = scene.frame(i);
    tracked += slam.track(f.color, f.depth, f.timestamp).state == tracking::TrackingState::kOk;
  }
  return tracked;
}

TEST(ContinueMapping, SecondHalfRelocalizesIntoTheSavedMapAndExtendsIt) {
  const SyntheticRgbdScene scene = walk();
  const Trajectory truth = truth_of(scene);
  const auto dir = testing::temp_dir("continue_mapping");

  // The whole walk in one go: the reference.
  double one_go_mm = 0.0;
  {
    System slam(scene.settings(), vocabulary(), sequential());
    ASSERT_EQ(track(slam, scene, 0, kFrames), kFrames);
    slam.shutdown();
    one_go_mm = 1e3 * eval::compute_ate(truth, slam.keyframe_trajectory()).translation.rmse;
  }

  // First half, saved while mapping still runs (a live save), then finished and saved again.
  std::size_t first_keyframes = 0;
  {
    System slam(scene.settings(), vocabulary(), sequential());
    ASSERT_EQ(track(slam, scene, 0, kHalf), kHalf);
    const auto live = slam.save_map(dir / "first.db");
    EXPECT_GT(live.keyframes, 0u);
    slam.shutdown();
    const auto report = slam.save_map(dir / "first.db");
    first_keyframes = report.keyframes;
  }
  ASSERT_GE(first_keyframes, 2u);

  // Loaded into a new System (as a registered map would be: its frame must carry over).
  mapdb::LoadedMap loaded = mapdb::load_map(dir / "first.db", vocabulary());
  loaded.metadata.frame_name = "scan";
  System slam(scene.settings(), vocabulary(), sequential(), std::move(loaded));
  const auto first = scene.frame(kHalf);
  const auto r = slam.track(first.color, first.depth, first.timestamp);
  EXPECT_EQ(r.state, tracking::TrackingState::kOk);
  EXPECT_TRUE(r.relocalized);
  EXPECT_EQ(track(slam, scene, kHalf + 1, kFrames), kFrames - kHalf - 1);
  slam.shutdown();

  // One map: the new keyframes joined the old ones, every relation consistent, and the first
  // half's keyframes did not move to another frame.
  const Trajectory combined = slam.keyframe_trajectory();
  EXPECT_GT(combined.size(), first_keyframes);
  EXPECT_EQ(slam.with_map([](const map::Map& m) { return test_support::map_problem(m); }), "");
  EXPECT_GE(slam.trajectory().size(), static_cast<std::size_t>(kFrames - kHalf));
  const double combined_mm = 1e3 * eval::compute_ate(truth, combined).translation.rmse;
  // (A handful of keyframes in this small room: millimetres apart are noise, hence the floor.
  // The twin building's continued map is the real measure: README, "Continuing a map".)
  EXPECT_LT(combined_mm, std::max(1.5 * one_go_mm, 6.0)) << "one go " << one_go_mm << " mm";
  std::cout << "keyframe ATE: one go " << one_go_mm << " mm, first half + continued " << combined_mm
            << " mm (" << first_keyframes << " + " << combined.size() - first_keyframes
            << " keyframes)\n";
  // The same frame without any alignment: the continued keyframes sit where the truth puts
  // them in the first half's frame.
  const eval::AteResult unaligned = eval::compute_ate(truth_in_first_camera(scene), combined,
                                                      {.alignment = eval::Alignment::kNone});
  EXPECT_LT(unaligned.translation.rmse, 0.01);

  // Saved again: the frame name is kept, and the file has both halves.
  const auto saved = slam.save_map(dir / "both.db");
  EXPECT_EQ(saved.keyframes, combined.size());
  EXPECT_EQ(mapdb::read_map_info(dir / "both.db").metadata.frame_name, "scan");
}

TEST(ContinueMapping, ARecordingOfAnotherPlaceAddsNothing) {
  const SyntheticRgbdScene here = walk(7), elsewhere = walk(1234);
  const auto dir = testing::temp_dir("continue_elsewhere");
  {
    System slam(here.settings(), vocabulary(), sequential());
    ASSERT_EQ(track(slam, here, 0, kHalf), kHalf);
    slam.shutdown();
    slam.save_map(dir / "here.db");
  }
  const auto before = mapdb::read_map_info(dir / "here.db").counts;
  const auto system =
      open_system(elsewhere.settings(), vocabulary(), sequential(), dir / "here.db");
  EXPECT_EQ(track(*system, elsewhere, 0, 20), 0);
  system->shutdown();
  const auto s = system->summary();
  EXPECT_EQ(s.keyframes, before.keyframes);
  EXPECT_EQ(s.points, before.points);
  EXPECT_EQ(s.lost, 20u);
}

// The relocalization gate: soon after the last tracked frame, a relocalized pose farther than
// the camera can have moved is refused (a look-alike place); later it is accepted. Here the
// gate is set tight (1 cm, no speed) so that a real place a few centimetres on is "too far".
TEST(RelocalizationGate, RefusesAJumpSoonAfterTrackingAndAcceptsItLater) {
  const SyntheticRgbdScene scene = walk();
  SystemOptions options = sequential();
  options.tracking.reloc_gate_m = 0.01;
  options.tracking.reloc_gate_speed = 0.0;
  options.tracking.reloc_gate_seconds = 2.0;
  System slam(scene.settings(), vocabulary(), options);
  ASSERT_EQ(track(slam, scene, 0, 12), 12);
  const double t_last = scene.frame(11).timestamp;
  const auto far = scene.frame(40);
  ASSERT_GT(
      (scene.world_from_cam(40).translation() - scene.world_from_cam(11).translation()).norm(),
      0.02);
  const cv::Mat blank(far.color.size(), far.color.type(), cv::Scalar::all(0));
  EXPECT_EQ(slam.track(blank, far.depth, t_last + 0.03).state, tracking::TrackingState::kLost);
  // 0.1 s after the last tracked frame: refused, however good the match.
  EXPECT_EQ(slam.track(far.color, far.depth, t_last + 0.1).state, tracking::TrackingState::kLost);
  // After the gate's time: anywhere.
  const auto r = slam.track(far.color, far.depth, t_last + 2.5);
  EXPECT_EQ(r.state, tracking::TrackingState::kOk);
  EXPECT_TRUE(r.relocalized);
  EXPECT_EQ(slam.summary().relocalizations, 1);
}

}  // namespace
}  // namespace coloc::slam::system
