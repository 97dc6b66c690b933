// The SLAM pipeline every entry point calls (slam/pipeline): the real 37-frame TUM fr1/xyz clip
// from frames to an evaluated, globally adjusted map; two runs of a recording give the same map
// (so `coloc map`, rgbd_tum and a library user agree); a source without ground truth gives no
// ATE; a source with no usable frame is an error. Features extracted ahead on a thread of their
// own are the ones tracking would extract, in order, so the map does not change.
#include <gtest/gtest.h>

#include <optional>

#include "slam/core/error.hpp"
#include "slam/dataset/frame_source.hpp"
#include "slam/dataset/sequence.hpp"
#include "slam/pipeline/extract_ahead.hpp"
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

TEST(Pipeline, ExtractingAheadLeavesTheMapAsItIs) {
  COLOC_REQUIRE_DATA(dir, "tum_fr1_xyz_37f");
  const auto sequence = dataset::open_sequence(dir);
  const auto settings = tum1_settings();
  const RunResult ahead = run_slam(*sequence, settings, vocabulary(), {.progress = false});
  const RunResult inline_ =
      run_slam(*sequence, settings, vocabulary(), {.extract_ahead = 0, .progress = false});
  EXPECT_EQ(ahead.summary.extracted_ahead, sequence->size());
  EXPECT_EQ(inline_.summary.extracted_ahead, 0u);
  ASSERT_EQ(ahead.keyframes.size(), inline_.keyframes.size());
  ASSERT_EQ(ahead.trajectory.size(), inline_.trajectory.size());
  for (std::size_t i = 0; i < ahead.trajectory.size(); ++i) {
    EXPECT_LT((ahead.trajectory[i].world_from_cam.translation() -
               inline_.trajectory[i].world_from_cam.translation())
                  .norm(),
              1e-9)
        << "frame " << i;
  }
}

// Frames of a sequence; frame `bad` throws instead (an unreadable file the source cannot skip)
// and frame `odd` has a 16-bit two-channel image, which no camera gives.
class TroubledFrames final : public dataset::FrameSource {
 public:
  TroubledFrames(const dataset::Sequence& sequence, std::size_t bad, std::size_t odd)
      : source_(dataset::frames_of(sequence)), bad_(bad), odd_(odd) {}
  std::optional<dataset::Frame> next() override {
    auto frame = source_->next();
    if (frame && frame->index == bad_) throw Error("frame " + std::to_string(bad_) + " broken");
    if (frame && frame->index == odd_) frame->color = cv::Mat(48, 64, CV_16UC2, cv::Scalar(7, 7));
    return frame;
  }

 private:
  std::unique_ptr<dataset::FrameSource> source_;
  std::size_t bad_, odd_;
};

TEST(ExtractAhead, HandsOutTheFramesInOrderWithTheFeaturesTrackingWouldExtract) {
  COLOC_REQUIRE_DATA(dir, "tum_fr1_xyz_37f");
  const auto sequence = dataset::open_sequence(dir);
  const auto settings = tum1_settings();
  const features::ExtractorOptions options{.n_features = settings.orb.n_features};
  const Camera& camera = settings.camera;
  TroubledFrames source(*sequence, 12, 5);
  ExtractAhead ahead(source, tracking::FeatureExtraction(options, camera, settings.rgb_order),
                     settings.rgb_order, 3);
  tracking::FeatureExtraction here(options, camera, settings.rgb_order);
  for (std::size_t i = 0; i < 12; ++i) {
    auto item = ahead.next();
    ASSERT_TRUE(item);
    EXPECT_EQ(item->frame.index, i);
    if (i == 5) {
      EXPECT_FALSE(item->features) << "left to tracking, which names what is wrong";
      continue;
    }
    ASSERT_TRUE(item->features);
    const tracking::ImageFeatures expected = here(item->frame.color);
    const auto& got = item->features->features;
    ASSERT_EQ(got.size(), expected.features.size());
    ASSERT_GT(got.size(), 500u);
    for (std::size_t k = 0; k < got.size(); ++k) {
      EXPECT_EQ(got.keypoints[k].ux, expected.features.keypoints[k].ux);
      EXPECT_EQ(got.keypoints[k].level, expected.features.keypoints[k].level);
      EXPECT_EQ(got.descriptors[k], expected.features.descriptors[k]);
    }
  }
  EXPECT_THROW(ahead.next(), Error) << "the source's error, at its frame";
  EXPECT_FALSE(ahead.next());
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
