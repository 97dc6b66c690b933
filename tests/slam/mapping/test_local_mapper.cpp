// Local mapping as a pipeline stage: the tracker's keyframe sink, with an output of its own (where
// a loop closer sits) and pause/resume for a loop correction.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <thread>

#include "slam/mapping/local_mapper.hpp"
#include "slam/synthetic/synthetic_scene.hpp"
#include "slam/tracking/tracker.hpp"
#include "tests/slam/support/pipeline.hpp"
#include "tests/slam/support/slam_test_support.hpp"

namespace coloc::slam::mapping {
namespace {

using test_support::RecordingSink;

struct Pipeline {
  explicit Pipeline(const synthetic::SyntheticRgbdScene& scene, bool wait_for_sink = true)
      : inputs(test_support::tracker_inputs(scene.settings())),
        mapper(shared, test_support::vocabulary(), nullptr, 0.0, {}, &output),
        tracker(shared, &mapper, test_support::vocabulary(), inputs.geometry, inputs.extractor,
                inputs.camera, options(wait_for_sink)) {
    mapper.start();
  }
  static tracking::TrackingOptions options(bool wait_for_sink) {
    tracking::TrackingOptions o;
    o.wait_for_sink = wait_for_sink;
    return o;
  }
  tracking::TrackingResult track(const synthetic::SyntheticRgbdScene& scene, int i) {
    const synthetic::SyntheticFrame f = scene.frame(i);
    return tracker.track(f.color, f.depth, f.timestamp);
  }

  map::SharedMap shared;
  RecordingSink output;
  test_support::TrackerInputs inputs;
  LocalMapper mapper;
  tracking::Tracker tracker;
};

TEST(LocalMapper, HandsEveryMappedKeyframeOnInOrder) {
  const synthetic::SyntheticRgbdScene scene;
  Pipeline p(scene);
  std::size_t made = 0;
  for (int i = 0; i < scene.size(); ++i) {
    const auto r = p.track(scene, i);
    ASSERT_EQ(r.state, tracking::TrackingState::kOk) << "frame " << i;
    made += r.keyframe ? 1 : 0;
  }
  p.mapper.wait_idle();
  const std::vector<KeyframeId> out = p.output.ids();
  ASSERT_GE(out.size(), 3u);
  EXPECT_EQ(out.size(), made);
  EXPECT_TRUE(std::is_sorted(out.begin(), out.end()));
  EXPECT_EQ(p.mapper.stats().keyframes, static_cast<int>(out.size()));
}

TEST(LocalMapper, PauseHoldsKeyframesAndTrackingMakesNoneUntilResume) {
  const synthetic::SyntheticRgbdScene scene;
  Pipeline p(scene);
  int i = 0;
  for (; i < 15; ++i)
    p.track(scene, i);
  p.mapper.wait_idle();
  const int mapped = p.mapper.stats().keyframes;

  p.mapper.pause();
  EXPECT_TRUE(p.mapper.paused());
  EXPECT_FALSE(p.mapper.accepting());
  for (; i < 30; ++i) {
    const auto r = p.track(scene, i);
    EXPECT_EQ(r.state, tracking::TrackingState::kOk) << "frame " << i;  // tracking goes on
    EXPECT_FALSE(r.keyframe) << "frame " << i;
  }
  // A keyframe pushed meanwhile waits (the mapper may hold it, unprocessed).
  ASSERT_TRUE(p.mapper.push({p.output.ids().front(), {}}));
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_FALSE(p.mapper.idle());
  EXPECT_TRUE(p.mapper.paused());
  EXPECT_EQ(p.mapper.stats().keyframes, mapped);

  p.mapper.resume();
  p.mapper.wait_idle();
  EXPECT_FALSE(p.mapper.paused());
  EXPECT_TRUE(p.mapper.accepting());
  EXPECT_EQ(p.mapper.stats().keyframes, mapped + 1);
  EXPECT_EQ(test_support::map_problem(p.shared.map), "");
}

TEST(LocalMapper, StopEndsAPausedMapper) {
  const synthetic::SyntheticRgbdScene scene;
  Pipeline p(scene);
  for (int i = 0; i < 5; ++i)
    p.track(scene, i);
  p.mapper.pause();
  ASSERT_TRUE(p.mapper.push({p.output.ids().front(), {}}));
  p.mapper.stop();  // must not hang on the paused thread
  EXPECT_FALSE(p.mapper.push({p.output.ids().front(), {}}));
}

}  // namespace
}  // namespace coloc::slam::mapping
