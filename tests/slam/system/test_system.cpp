// End-to-end tests of the RGB-D SLAM system: a synthetic scene with a known trajectory, the
// real 37-frame TUM fr1/xyz clip (with our settings, and with users' ORB-SLAM3 file, whose
// rolling-shutter readout is estimated), relocalization after a jump, and shutdown in the middle
// of local mapping.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <string>
#include <variant>

#include "markers/dictionary.hpp"
#include "markers/synthetic.hpp"
#include "slam/core/error.hpp"
#include "slam/dataset/sequence.hpp"
#include "slam/eval/trajectory_error.hpp"
#include "slam/settings/settings.hpp"
#include "slam/synthetic/synthetic_scene.hpp"
#include "slam/system/system.hpp"
#include "tests/slam/support/slam_test_support.hpp"
#include "tests/testing/data.hpp"

namespace coloc::slam::system {
namespace {

using synthetic::SyntheticFrame;
using synthetic::SyntheticRgbdScene;
using synthetic::SyntheticSceneOptions;

using test_support::source_dir;
using test_support::vocabulary;

settings::Settings tum1_settings() {
  return settings::load_settings(source_dir() / "Examples/RGB-D/TUM1.yaml");
}

TEST(SlamSystem, SyntheticSceneTracksWithMillimetreAccuracy) {
  SyntheticSceneOptions scene_options;
  scene_options.frames = 30;
  const SyntheticRgbdScene scene(scene_options);
  SystemOptions options;
  options.tracking.wait_for_sink = true;
  options.detect_markers = false;
  System slam(scene.settings(), vocabulary(), options);
  Trajectory truth;
  for (int i = 0; i < scene.size(); ++i) {
    const SyntheticFrame f = scene.frame(i);
    truth.push_back({f.timestamp, f.world_from_cam});
    const auto r = slam.track(f.color, f.depth, f.timestamp);
    EXPECT_EQ(r.state, tracking::TrackingState::kOk) << "frame " << i;
  }
  slam.shutdown();
  const Trajectory estimate = slam.trajectory();
  ASSERT_EQ(estimate.size(), truth.size());
  const auto ate = eval::compute_ate(truth, estimate);
  EXPECT_LT(ate.translation.rmse, 0.005);
  const auto s = slam.summary();
  EXPECT_GE(s.keyframes, 2u);
  EXPECT_GT(s.points, 500u);
  RecordProperty("ate_mm", std::to_string(1e3 * ate.translation.rmse));
  std::cout << "synthetic ATE RMSE " << 1e3 * ate.translation.rmse << " mm\n"
            << s.describe() << "\n";
}

// A marker printed on the synthetic room's far wall: every keyframe must store its
// observation (id and four corners) where the true pose projects the corners.
TEST(SlamSystem, KeyframesStoreMarkerObservations) {
  SyntheticSceneOptions scene_options;
  scene_options.frames = 12;
  const SyntheticRgbdScene scene(scene_options);
  settings::Settings settings = scene.settings();
  settings.markers.dictionary = "DICT_4X4_50";
  const auto dictionary = markers::make_dictionary(settings.markers.dictionary);
  const double size = 0.5;
  settings.markers.size = size;
  // On the far wall (z = 3), facing the camera: marker x = world x, y = -world y, z = -world z.
  Eigen::Matrix3d r;
  r << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  const SE3 world_from_marker(SO3::from_matrix(r), Eigen::Vector3d(0.3, -0.2, 3.0));
  const std::array<Eigen::Vector3d, 4> corners = {Eigen::Vector3d(-size / 2, size / 2, 0),
                                                  {size / 2, size / 2, 0},
                                                  {size / 2, -size / 2, 0},
                                                  {-size / 2, -size / 2, 0}};
  SystemOptions options;
  options.tracking.wait_for_sink = true;
  options.tracking.max_frames_between_keyframes = 4;
  System slam(settings, vocabulary(), options);
  std::map<double, SE3> truth;
  for (int i = 0; i < scene.size(); ++i) {
    SyntheticFrame f = scene.frame(i);
    cv::Mat grey;
    cv::cvtColor(f.color, grey, cv::COLOR_BGR2GRAY);
    markers::render_marker(grey, settings.camera, f.world_from_cam.inverse() * world_from_marker,
                           *dictionary, 7, size);
    cv::cvtColor(grey, f.color, cv::COLOR_GRAY2BGR);
    truth[f.timestamp] = f.world_from_cam;
    slam.track(f.color, f.depth, f.timestamp);
  }
  slam.shutdown();
  const int checked = slam.with_map([&](const map::Map& m) {
    int n = 0;
    for (const auto& [id, kf] : m.keyframes()) {
      EXPECT_EQ(kf.markers.size(), 1u) << "keyframe " << id;
      if (kf.markers.size() != 1) continue;
      EXPECT_EQ(kf.markers[0].id, 7);
      EXPECT_EQ(kf.marker_size, size);
      const SE3 cam_from_marker = truth.at(kf.frame.timestamp).inverse() * world_from_marker;
      for (int c = 0; c < 4; ++c) {
        const Eigen::Vector2d expected =
            project(settings.camera, cam_from_marker * corners[static_cast<std::size_t>(c)]);
        EXPECT_LT((kf.markers[0].corners[static_cast<std::size_t>(c)] - expected).norm(), 1.0)
            << "corner " << c;
      }
      ++n;
    }
    return n;
  });
  EXPECT_GE(checked, 2);
  EXPECT_EQ(slam.summary().mapping.markers, checked);
}

struct TumRun {
  Trajectory estimate;
  SystemSummary summary;
};

TumRun run_tum(const std::filesystem::path& dir, std::size_t skip_from, std::size_t skip_count,
               bool sequential) {
  const auto sequence = dataset::open_sequence(dir);
  SystemOptions options;
  options.tracking.wait_for_sink = sequential;
  System slam(tum1_settings(), vocabulary(), options);
  for (std::size_t i = 0; i < sequence->size(); ++i) {
    if (i >= skip_from && i < skip_from + skip_count) continue;
    const auto f = sequence->frame(i);
    slam.track(f.color, f.depth, f.timestamp);
  }
  slam.shutdown();
  return {slam.trajectory(), slam.summary()};
}

TEST(SlamSystem, TumFr1Xyz37FramesWithinThreeCentimetres) {
  COLOC_REQUIRE_DATA(dir, "tum_fr1_xyz_37f");
  const auto sequence = dataset::open_sequence(dir);
  const TumRun run = run_tum(dir, 0, 0, true);
  EXPECT_EQ(run.summary.lost, 0u);
  EXPECT_EQ(run.estimate.size(), sequence->size());
  const auto ate = eval::compute_ate(sequence->ground_truth(), run.estimate);
  EXPECT_LT(ate.translation.rmse, 0.03);
  std::cout << "tum_fr1_xyz_37f ATE RMSE " << 1e3 * ate.translation.rmse << " mm over "
            << ate.translation.count << " poses\n"
            << run.summary.describe() << "\n";
}

// Users' ORB-SLAM3 settings carry no Camera.readoutTime: the Kinect's rolling-shutter readout is
// then estimated while mapping (sequential runs: the same figures on any machine). It lands in
// the summary and in the map's metadata, and the trajectory beats the uncompensated one.
TEST(SlamSystem, EstimatesTheRollingShutterReadoutWhenTheSettingsGiveNone) {
  COLOC_REQUIRE_DATA(dir, "tum_fr1_xyz_37f");
  COLOC_REQUIRE_DATA(config, "orbslam_configs/ORB_SLAM3_v1.0_RGB-D_TUM1.yaml");
  const auto sequence = dataset::open_sequence(dir);
  const settings::Settings settings = settings::load_settings(config);
  ASSERT_FALSE(settings.readout_time.has_value());
  struct Run {
    double ate_m = 0.0;
    std::optional<double> summary_readout, saved_readout;
  };
  auto run = [&](bool estimate, double start = 0.5, std::size_t min_keyframes = 0) {
    SystemOptions options;
    options.tracking.wait_for_sink = true;
    options.detect_markers = false;
    options.mapping.estimate_readout = estimate;
    options.mapping.readout_start = start;
    options.mapping.readout_min_keyframes = min_keyframes;
    System slam(settings, vocabulary(), options);
    for (std::size_t i = 0; i < sequence->size(); ++i) {
      const auto f = sequence->frame(i);
      slam.track(f.color, f.depth, f.timestamp);
    }
    slam.shutdown();
    const auto map_file = testing::temp_dir("readout_estimate") / "map.db";
    slam.save_map(map_file);
    return Run{eval::compute_ate(sequence->ground_truth(), slam.trajectory()).translation.rmse,
               slam.summary().estimated_readout,
               mapdb::read_map_info(map_file).metadata.estimated_readout};
  };
  {
    // By default the estimate starts at half the frame interval.
    const System fresh(settings, vocabulary(), SystemOptions{});
    ASSERT_TRUE(fresh.summary().estimated_readout.has_value());
    EXPECT_DOUBLE_EQ(*fresh.summary().estimated_readout, 0.5 / settings.fps);
  }
  const Run with = run(true), without = run(false);
  ASSERT_TRUE(with.summary_readout.has_value());
  EXPECT_GT(*with.summary_readout, 0.003);  // the Kinect v1 reads its rows over about 20 ms
  EXPECT_LT(*with.summary_readout, 0.05);
  EXPECT_EQ(with.saved_readout, with.summary_readout);
  EXPECT_FALSE(without.summary_readout.has_value());
  EXPECT_FALSE(without.saved_readout.has_value());
  EXPECT_LT(with.ate_m, without.ate_m);
  // From nothing, the 37 frames' keyframes alone move the estimate into the band.
  const Run from_zero = run(true, 0.0);
  ASSERT_TRUE(from_zero.summary_readout.has_value());
  EXPECT_GT(*from_zero.summary_readout, 0.003);
  EXPECT_LT(*from_zero.summary_readout, 0.05);
  // Windows smaller than readout_min_keyframes leave the estimate where it started: the 37
  // frames make fewer than 20 keyframes.
  const Run held = run(true, 0.0, 20);
  ASSERT_TRUE(held.summary_readout.has_value());
  EXPECT_EQ(*held.summary_readout, 0.0);
  std::cout << "readout estimated " << 1e3 * *with.summary_readout << " ms; ATE "
            << 1e3 * with.ate_m << " mm (without: " << 1e3 * without.ate_m << " mm)\n";
}

// Tracks 8 frames, loses track on two blank frames, then jumps 20 frames ahead: tracking must
// recover by relocalization and the recovered pose must agree with the ground truth (relative
// to the first frame, which defines the map's world frame) within 5 cm.
TEST(SlamSystem, RelocalizesAfterLosingTrackAndJumpingTwentyFrames) {
  COLOC_REQUIRE_DATA(dir, "tum_fr1_xyz_37f");
  const auto sequence = dataset::open_sequence(dir);
  const Trajectory& gt = sequence->ground_truth();
  SystemOptions options;
  options.tracking.wait_for_sink = true;
  options.detect_markers = false;
  System slam(tum1_settings(), vocabulary(), options);
  for (std::size_t i = 0; i < 8; ++i) {
    const auto f = sequence->frame(i);
    ASSERT_EQ(slam.track(f.color, f.depth, f.timestamp).state, tracking::TrackingState::kOk);
  }
  const auto f0 = sequence->frame(7);
  const cv::Mat blank(f0.color.size(), f0.color.type(), cv::Scalar::all(0));
  for (int k = 0; k < 2; ++k) {
    EXPECT_EQ(slam.track(blank, f0.depth, f0.timestamp + 0.01 * (k + 1)).state,
              tracking::TrackingState::kLost);
  }
  auto nearest_gt = [&](double t) {
    const StampedPose* best = &gt.front();
    for (const auto& p : gt)
      if (std::abs(p.timestamp - t) < std::abs(best->timestamp - t)) best = &p;
    return best->world_from_cam;
  };
  const SE3 gt_world_from_first = nearest_gt(sequence->timestamp(0));
  bool recovered = false;
  for (std::size_t i = 28; i < sequence->size(); ++i) {
    const auto f = sequence->frame(i);
    const auto r = slam.track(f.color, f.depth, f.timestamp);
    if (!recovered && r.state == tracking::TrackingState::kOk) {
      recovered = true;
      EXPECT_TRUE(r.relocalized);
      EXPECT_LE(i, 30u) << "recovered only at frame " << i;
      const SE3 expected = gt_world_from_first.inverse() * nearest_gt(f.timestamp);
      const SE3 estimated = r.cam_from_world.inverse();
      EXPECT_LT(translation_distance(expected, estimated), 0.05);
      std::cout << "relocalized at frame " << i << ", error "
                << 1e3 * translation_distance(expected, estimated) << " mm\n";
    }
  }
  EXPECT_TRUE(recovered);
  EXPECT_GE(slam.summary().relocalizations, 1);
}

// Local mapping runs concurrently with long bundle adjustments; the sequence ends while the
// mapper is busy. Shutdown must return (a hang fails the test by ctest's timeout), leave a
// consistent map and a readable trajectory. Run under -fsanitize=address for the leak check.
TEST(SlamSystem, ShutsDownCleanlyWhileLocalMappingIsBusy) {
  COLOC_REQUIRE_DATA(dir, "tum_fr1_xyz_37f");
  const auto sequence = dataset::open_sequence(dir);
  SystemOptions options;
  options.mapping.ba.iterations_robust = 200;  // BAs long enough to be cut
  options.mapping.ba.iterations_refine = 200;
  options.tracking.max_frames_between_keyframes = 2;
  options.detect_markers = false;
  auto slam = std::make_unique<System>(tum1_settings(), vocabulary(), options);
  int keyframes = 0;
  for (std::size_t i = 0; i < 12; ++i) {
    const auto f = sequence->frame(i);
    keyframes += slam->track(f.color, f.depth, f.timestamp).keyframe ? 1 : 0;
  }
  slam->shutdown();
  slam->shutdown();  // idempotent
  const SystemSummary s = slam->summary();
  EXPECT_LE(s.mapping.keyframes, keyframes);
  EXPECT_EQ(slam->trajectory().size(), 12u);
  const bool consistent = slam->with_map([](const map::Map& m) {
    for (const auto& [id, p] : m.points()) {
      for (const auto& [k, idx] : p.observations) {
        const map::Keyframe* kf = m.keyframe(k);
        if (!kf || kf->frame.points[idx] != id) return false;
      }
    }
    return true;
  });
  EXPECT_TRUE(consistent);
  slam.reset();  // destructor after shutdown: nothing left to join
}

// Settings files without Camera.width/height (ORB-SLAM's older files) work: the first image
// gives the size. An image of another size afterwards is an error naming the key.
TEST(SlamSystem, ImageSizeFromTheFirstFrameWhenSettingsOmitIt) {
  SyntheticSceneOptions scene_options;
  scene_options.frames = 8;
  const SyntheticRgbdScene scene(scene_options);
  settings::Settings settings = scene.settings();
  std::visit([](auto& c) { c.width = c.height = 0; }, settings.camera);
  SystemOptions options;
  options.tracking.wait_for_sink = true;
  options.detect_markers = false;
  System slam(settings, vocabulary(), options);
  for (int i = 0; i < scene.size(); ++i) {
    const SyntheticFrame f = scene.frame(i);
    EXPECT_EQ(slam.track(f.color, f.depth, f.timestamp).state, tracking::TrackingState::kOk);
  }
  const SyntheticFrame f = scene.frame(0);
  cv::Mat small_color, small_depth;
  cv::resize(f.color, small_color, {320, 240});
  cv::resize(f.depth, small_depth, {320, 240}, 0, 0, cv::INTER_NEAREST);
  try {
    slam.track(small_color, small_depth, 100.0);
    ADD_FAILURE() << "a 320x240 image after 640x480 ones was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "Camera.width");
    EXPECT_NE(std::string(e.what()).find("320x240"), std::string::npos) << e.what();
  }
  EXPECT_EQ(slam.summary().tracked, static_cast<std::size_t>(scene.size()));
}

}  // namespace
}  // namespace coloc::slam::system
