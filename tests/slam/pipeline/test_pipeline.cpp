// The SLAM pipeline every entry point calls (slam/pipeline): the real 37-frame TUM fr1/xyz clip
// from frames to an evaluated, globally adjusted map; two runs of a recording give the same map
// (so `coloc map`, rgbd_tum and a library user agree); a source without ground truth gives no
// ATE; a source with no usable frame is an error.
#include <gtest/gtest.h>

#include <optional>

#include "slam/core/error.hpp"
#include "slam/dataset/frame_source.hpp"
#include "slam/dataset/sequence.hpp"
#include "slam/pipeline/pipeline.hpp"
#include "slam/settings/settings.hpp"
#include "tests/slam/support/slam_test_support.hpp"
#include "tests/testing/data.hpp"

namespace coloc::slam::pipeline {
namespace {

using test_support::source_dir;
using test_support::vocabulary;

settings::Settings tum1_settings() {
  return settings::load_settings(source_dir() / "Examples/RGB-D/TUM1.yaml");
}

TEST(Pipeline, TumFr1XyzFromFramesToAnEvaluatedMap) {
  COLOC_REQUIRE_DATA(dir, "tum_fr1_xyz_37f");
  const auto sequence = dataset::open_sequence(dir);
  const RunResult r = run_slam(*sequence, tum1_settings(), vocabulary(), {.progress = false});
  EXPECT_EQ(r.trajectory.size(), sequence->size());
  EXPECT_EQ(r.skipped_frames, 0u);
  EXPECT_GE(r.keyframes.size(), 2u);
  ASSERT_TRUE(r.global_ba.has_value()) << "the final global BA runs by default";
  ASSERT_TRUE(r.ate && r.ate_online && r.ate_keyframes);
  EXPECT_LT(r.ate->translation.rmse, 0.03);
  EXPECT_EQ(r.ate->translation.count, sequence->size());
}

TEST(Pipeline, ARecordingGivesTheSameMapEveryRun) {
  COLOC_REQUIRE_DATA(dir, "tum_fr1_xyz_37f");
  const auto sequence = dataset::open_sequence(dir);
  const auto settings = tum1_settings();
  const RunResult a = run_slam(*sequence, settings, vocabulary(), {.progress = false});
  const RunResult b = run_slam(*sequence, settings, vocabulary(), {.progress = false});
  ASSERT_EQ(a.keyframes.size(), b.keyframes.size());
  ASSERT_EQ(a.trajectory.size(), b.trajectory.size());
  for (std::size_t i = 0; i < a.trajectory.size(); ++i) {
    EXPECT_EQ(a.trajectory[i].timestamp, b.trajectory[i].timestamp);
    EXPECT_LT((a.trajectory[i].world_from_cam.translation() -
               b.trajectory[i].world_from_cam.translation())
                  .norm(),
              1e-9)
        << "frame " << i;
  }
}

TEST(Pipeline, FramesWithoutGroundTruthHaveNoAccuracyFigures) {
  COLOC_REQUIRE_DATA(dir, "tum_fr1_xyz_37f");
  const auto sequence = dataset::open_sequence(dir);
  const auto frames = dataset::frames_of(*sequence);
  const RunResult r = run_slam(*frames, nullptr, tum1_settings(), vocabulary(),
                               {.global_ba = false, .progress = false});
  EXPECT_EQ(r.trajectory.size(), sequence->size());
  EXPECT_FALSE(r.ate.has_value());
  EXPECT_FALSE(r.global_ba.has_value());
}

// A source that ends before its first frame: nothing was tracked, and the run says so.
class NoFrames final : public dataset::FrameSource {
 public:
  std::optional<dataset::Frame> next() override { return std::nullopt; }
};

TEST(Pipeline, NoFrameIsAnError) {
  NoFrames frames;
  EXPECT_THROW(run_slam(frames, nullptr, tum1_settings(), vocabulary(), {.progress = false}),
               Error);
}

}  // namespace
}  // namespace coloc::slam::pipeline
