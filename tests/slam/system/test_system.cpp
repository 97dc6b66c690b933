// End-to-end tests of the RGB-D SLAM system: a synthetic scene with a known trajectory, the
// real 37-frame TUM fr1/xyz clip, relocalization after a jump, and shutdown in the middle of
// local mapping.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <memory>

#include "slam/dataset/sequence.hpp"
#include "slam/eval/trajectory_error.hpp"
#include "slam/settings/settings.hpp"
#include "slam/system/synthetic_scene.hpp"
#include "slam/system/system.hpp"
#include "tests/testing/data.hpp"

namespace coloc::slam::system {
namespace {

std::filesystem::path source_dir() {
  if (const char* env = std::getenv("COLOC_SOURCE_DIR")) return env;
  return COLOC_TEST_SOURCE_DIR;
}

// Loaded once: the vocabulary takes a moment to read.
const bow::Vocabulary& vocabulary() {
  static const bow::Vocabulary v =
      bow::Vocabulary::load(source_dir() / "Vocabulary/coloc_orb_k10_L5.cvoc");
  return v;
}

settings::Settings tum1_settings() {
  return settings::load_settings(source_dir() / "Examples/RGB-D/TUM1.yaml");
}

TEST(SlamSystem, SyntheticSceneTracksWithMillimetreAccuracy) {
  SyntheticSceneOptions scene_options;
  scene_options.frames = 30;
  const SyntheticRgbdScene scene(scene_options);
  SystemOptions options;
  options.sequential_mapping = true;
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

struct TumRun {
  Trajectory estimate;
  SystemSummary summary;
};

TumRun run_tum(const std::filesystem::path& dir, std::size_t skip_from, std::size_t skip_count,
               bool sequential) {
  const auto sequence = dataset::open_sequence(dir);
  SystemOptions options;
  options.sequential_mapping = sequential;
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

}  // namespace
}  // namespace coloc::slam::system
