// The tracker on its own: it hands keyframes to whatever sink it is given, and without one it
// localizes in a fixed map (localization only) without adding anything to it.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <numbers>
#include <numeric>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <utility>

#include "slam/core/error.hpp"
#include "slam/eval/trajectory_error.hpp"
#include "slam/mapping/local_mapper.hpp"
#include "slam/synthetic/synthetic_scene.hpp"
#include "slam/tracking/tracker.hpp"
#include "tests/slam/support/pipeline.hpp"
#include "tests/slam/support/slam_test_support.hpp"

namespace coloc::slam::tracking {
namespace {

using synthetic::SyntheticFrame;
using synthetic::SyntheticRgbdScene;
using synthetic::SyntheticSceneOptions;
using test_support::RecordingSink;
using test_support::tracker_inputs;
using test_support::vocabulary;

constexpr double kBlurSigma = 3.0;  // pixels

Tracker make_tracker(map::SharedMap& shared, map::KeyframeSink* sink,
                     const SyntheticRgbdScene& scene, TrackingOptions options = {}) {
  const auto in = tracker_inputs(scene.settings());
  return Tracker(shared, sink, vocabulary(), in.geometry, in.extractor, in.camera, options);
}

TEST(Tracker, GreyConversionFollowsTheChannelOrder) {
  cv::Mat bgr(2, 2, CV_8UC3, cv::Scalar(200, 50, 10));  // blue-ish: B and R weigh differently
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  const cv::Mat from_bgr = to_grey(bgr, false), from_rgb = to_grey(rgb, true);
  EXPECT_EQ(cv::countNonZero(from_bgr != from_rgb), 0);
  EXPECT_NE(cv::countNonZero(to_grey(bgr, true) != from_bgr), 0);  // the order matters
  const cv::Mat grey(2, 2, CV_8UC1, cv::Scalar(77));
  EXPECT_EQ(to_grey(grey, true).data, grey.data);  // grey passes through, not copied
}

TEST(Tracker, LocalizationOnlyNeedsAMapWithKeyframes) {
  const SyntheticRgbdScene scene;
  map::SharedMap empty;
  EXPECT_THROW(make_tracker(empty, nullptr, scene), Error);
}

TEST(Tracker, MakesNoKeyframeWhileItsSinkDoesNotAccept) {
  const SyntheticRgbdScene scene;
  map::SharedMap shared;
  RecordingSink sink;
  sink.accept = false;
  Tracker tracker = make_tracker(shared, &sink, scene);
  for (int i = 0; i < scene.size(); ++i) {
    const SyntheticFrame f = scene.frame(i);
    EXPECT_EQ(tracker.track(f.color, f.depth, f.timestamp).state, TrackingState::kOk);
  }
  // Only the initial keyframe, which tracking needs to exist at all.
  EXPECT_EQ(sink.ids().size(), 1u);
  EXPECT_EQ(shared.map.keyframe_count(), 1u);
}

// While local mapping estimates the readout, tracking waits for it after each of the first
// readout_settle_keyframes keyframes (recorded frames only), and never when the readout is known.
TEST(Tracker, WaitsForTheSinkWhileTheReadoutSettles) {
  const SyntheticRgbdScene scene;
  TrackingOptions options;
  options.readout_settle_keyframes = 2;
  for (const bool estimating : {true, false}) {
    map::SharedMap shared;
    shared.estimate_readout = estimating;
    RecordingSink sink;
    Tracker tracker = make_tracker(shared, &sink, scene, options);
    for (int i = 0; i < scene.size(); ++i) {
      const SyntheticFrame f = scene.frame(i);
      tracker.track(f.color, f.depth, f.timestamp);
    }
    ASSERT_GT(sink.ids().size(), 2u);  // more keyframes than waits
    EXPECT_EQ(sink.waits.load(), estimating ? 2 : 0) << "estimating " << estimating;
  }
}

// While the readout is estimated, every keyframe after the first carries the rotation rate of
// its poses, so local mapping can tell readouts apart (a rate refined from the rows' shear would
// fit any readout). With a known readout, the first keyframe takes the rate of the pair it starts.
TEST(Tracker, KeyframesCarryTheRateOfTheirPoses) {
  const SyntheticRgbdScene scene;
  const double dt = 1.0 / 30.0;
  // The true rate over the pair that ends at frame i (the first: that starts at it).
  auto true_rate = [&](int i) {
    const int a = i == 0 ? 0 : i - 1;
    const SE3 b_from_a = scene.world_from_cam(a + 1).inverse() * scene.world_from_cam(a);
    return Eigen::Vector3d(-b_from_a.so3().log() / dt);
  };
  for (const bool estimating : {true, false}) {
    SCOPED_TRACE(estimating ? "readout estimated" : "readout known");
    map::SharedMap shared;
    shared.estimate_readout = estimating;
    shared.readout = 0.01;  // wrong (the scene has a global shutter): the rows' shear says 0
    RecordingSink sink;
    auto in = tracker_inputs(scene.settings());
    auto geometry = std::make_shared<frame::FrameGeometry>(*in.geometry);
    geometry->readout = estimating ? 0.0 : 0.01;
    Tracker tracker(shared, &sink, vocabulary(), geometry, in.extractor, in.camera, {});
    for (int i = 0; i < scene.size(); ++i) {
      const SyntheticFrame f = scene.frame(i);
      ASSERT_EQ(tracker.track(f.color, f.depth, f.timestamp).state, TrackingState::kOk);
    }
    ASSERT_GT(shared.map.keyframe_count(), 2u);
    for (const auto& [id, kf] : shared.map.keyframes()) {
      const frame::Frame& f = kf.frame;
      const int i = static_cast<int>(std::lround(f.timestamp / dt));
      if (i == 0) {
        EXPECT_EQ(f.shutter_rate.isZero(), estimating);
        if (estimating) continue;
      }
      if (!estimating && i > 0) continue;  // refined from the shear: checked elsewhere
      const Eigen::Vector3d truth = true_rate(i);
      // Two poses' errors over 33 ms: a few hundredths of a rad/s.
      ASSERT_GT(truth.norm(), 0.1) << "keyframe " << id.value();
      EXPECT_LT((f.shutter_rate - truth).norm(), 0.4 * truth.norm())
          << "keyframe " << id.value() << " at frame " << i << ": " << f.shutter_rate.transpose()
          << " against " << truth.transpose();
      EXPECT_EQ(f.shutter_readout, 0.01);
    }
  }
}

// The keyframe decision does not depend on how busy the mapper is (a replay, a paced run and a
// live camera decide alike): behind a mapper that is always busy (its queue empty) the same
// frames become keyframes as behind an idle one, each interrupting the BA. ORB-SLAM's rule
// (keyframe_needs_idle_mapper) makes one there only when tracking is weak or long after the last.
TEST(Tracker, DecidesKeyframesWhateverTheMapperIsDoing) {
  const SyntheticRgbdScene scene;
  auto run = [&](bool busy, bool needs_idle) {
    TrackingOptions options;
    options.keyframe_needs_idle_mapper = needs_idle;
    if (needs_idle) options.min_frames_between_keyframes = 0;
    map::SharedMap shared;
    RecordingSink sink;
    sink.busy = busy;
    Tracker tracker = make_tracker(shared, &sink, scene, options);
    std::vector<int> keyframes;
    for (int i = 0; i < scene.size(); ++i) {
      const SyntheticFrame f = scene.frame(i);
      const TrackingResult r = tracker.track(f.color, f.depth, f.timestamp);
      EXPECT_EQ(r.state, TrackingState::kOk);
      EXPECT_FALSE(r.keyframe_refused_busy);  // the sink's queue never fills
      if (r.keyframe) keyframes.push_back(i);
    }
    return std::pair(keyframes, sink.interrupts.load());
  };
  const auto [idle_keyframes, idle_interrupts] = run(false, false);
  const auto [busy_keyframes, busy_interrupts] = run(true, false);
  EXPECT_EQ(busy_keyframes, idle_keyframes);
  EXPECT_GT(idle_keyframes.size(), 2U);
  EXPECT_EQ(idle_interrupts, 0);
  // Every keyframe after the initial one asked for an interruption (a deferred one asks again).
  EXPECT_GE(busy_interrupts, static_cast<int>(busy_keyframes.size()) - 1);
  const auto [orb_keyframes, orb_interrupts] = run(true, true);
  EXPECT_LT(orb_keyframes.size(), busy_keyframes.size());
  EXPECT_GE(orb_interrupts, static_cast<int>(orb_keyframes.size()) - 1);
}

// `frames` of `scene` (indices, in order) tracked with a sink, frame `blurred` smeared by a
// Gaussian of `sigma` pixels: which became keyframes, and each frame's inliers.
struct TrackedRun {
  std::vector<int> keyframes;
  std::map<int, int> inliers;
  bool keyframe(int i) const {
    return std::find(keyframes.begin(), keyframes.end(), i) != keyframes.end();
  }
};

// The frames arrive one scene interval apart whichever frames they are, so that frames left out
// make the camera jump (the motion model predicts one interval's motion).
TrackedRun track_frames(const SyntheticRgbdScene& scene, const TrackingOptions& options,
                        const std::vector<int>& frames, int blurred = -1, double sigma = 0.0) {
  map::SharedMap shared;
  RecordingSink sink;
  Tracker tracker = make_tracker(shared, &sink, scene, options);
  TrackedRun run;
  const double interval = scene.frame(1).timestamp - scene.frame(0).timestamp;
  double timestamp = scene.frame(frames.front()).timestamp;
  for (int i : frames) {
    SyntheticFrame f = scene.frame(i);
    if (i == blurred) cv::GaussianBlur(f.color, f.color, cv::Size(), sigma);
    const auto r = tracker.track(f.color, f.depth, timestamp);
    timestamp += interval;
    EXPECT_EQ(r.state, TrackingState::kOk) << "frame " << i;
    run.inliers[i] = r.inliers;
    if (r.keyframe) run.keyframes.push_back(i);
  }
  return run;
}

TrackedRun track_with_a_blurred_frame(const SyntheticRgbdScene& scene,
                                      const TrackingOptions& options, int blurred, double sigma) {
  std::vector<int> all(static_cast<std::size_t>(scene.size()));
  std::iota(all.begin(), all.end(), 0);
  return track_frames(scene, options, all, blurred, sigma);
}

// A frame smeared by a fast turn tracks with a fraction of its neighbours' inliers, at a poorer
// pose; a keyframe made from it would anchor the map there (its pose and the points from its
// depth) until a BA frames later. The tracker puts the keyframe off to a sharper frame.
TEST(Tracker, PutsAKeyframeOffFromABlurredFrame) {
  const SyntheticRgbdScene scene;
  const int blurred = 12;
  TrackingOptions options;
  options.keyframe_defer_ratio = 0.0;
  const TrackedRun undeferred = track_with_a_blurred_frame(scene, options, blurred, kBlurSigma);
  // The blur costs most inliers, and without deferral the drop itself asks for a keyframe.
  ASSERT_LT(undeferred.inliers.at(blurred), undeferred.inliers.at(blurred - 1) / 2);
  ASSERT_TRUE(undeferred.keyframe(blurred));
  const TrackedRun deferred = track_with_a_blurred_frame(scene, {}, blurred, kBlurSigma);
  EXPECT_FALSE(deferred.keyframe(blurred));
  // Only put off: the sharp frames after it are still mapped.
  EXPECT_GE(deferred.keyframes.size() + 1, undeferred.keyframes.size());
}

// A keyframe made from a blurred frame all the same (no deferral left) holds few points seen
// twice, so the ratio test would not ask for another while the sharp frames after it track more
// than 0.75 x that few. The first sharp frame (twice the inliers) replaces it.
TEST(Tracker, ReplacesAKeyframeMadeFromABlurredFrame) {
  const SyntheticRgbdScene scene;
  const int blurred = 12;
  const double sigma = 2 * kBlurSigma;  // to under half the inliers
  TrackingOptions options;
  options.keyframe_defer_max = 0;  // the blurred frame becomes a keyframe all the same
  options.weak_reference_ratio = 0.0;
  options.min_frames_between_keyframes = 0;  // the frame after it may replace it at once
  const TrackedRun kept = track_with_a_blurred_frame(scene, options, blurred, sigma);
  ASSERT_TRUE(kept.keyframe(blurred));
  ASSERT_FALSE(kept.keyframe(blurred + 1));
  options.weak_reference_ratio = TrackingOptions{}.weak_reference_ratio;
  const TrackedRun replaced = track_with_a_blurred_frame(scene, options, blurred, sigma);
  EXPECT_TRUE(replaced.keyframe(blurred));
  EXPECT_TRUE(replaced.keyframe(blurred + 1));
}

// A frame tracked far off the motion model's prediction (fr1/rpy's blurred turn: 10-17 deg off
// with 50-100 inliers, where the true rate changes by ~3 deg per frame) is not trusted as a
// keyframe: its depth would become points at that pose. Here frames 12-19 of the walk are
// left out while the timestamps run on (track_frames), so frame 20 lands off the prediction as
// after a sudden turn and asks for a keyframe; the keyframe waits.
TEST(Tracker, PutsAKeyframeOffFromAFrameFarOffTheMotionModel) {
  const SyntheticRgbdScene scene;
  const int jump_to = 20;
  std::vector<int> frames(12);
  std::iota(frames.begin(), frames.end(), 0);
  for (int i = jump_to; i < jump_to + 6; ++i)
    frames.push_back(i);
  // The rotation between frame 20 and where the motion of frames 10-11 would have taken it.
  const auto cam_from_world = [&](int i) { return scene.world_from_cam(i).inverse(); };
  const SE3 predicted = cam_from_world(11) * scene.world_from_cam(10) * cam_from_world(11);
  const double off_deg =
      rotation_distance(cam_from_world(jump_to), predicted) * 180.0 / std::numbers::pi;
  ASSERT_GT(off_deg, 1.0);
  TrackingOptions options;
  options.keyframe_defer_ratio = 0.0;  // only the deviation decides here
  options.keyframe_defer_deviation_deg = 0.0;
  options.min_frames_between_keyframes = 0;  // frame 20 is tracked right after frame 11
  options.min_frames_between_slow_keyframes = 0;
  const TrackedRun ungated = track_frames(scene, options, frames);
  ASSERT_TRUE(ungated.keyframe(jump_to));  // the new view asks for a keyframe
  options.keyframe_defer_deviation_deg = off_deg / 2;
  const TrackedRun gated = track_frames(scene, options, frames);
  EXPECT_FALSE(gated.keyframe(jump_to));
  // Only put off: a later frame of the new view is mapped.
  EXPECT_GT(gated.keyframes.back(), jump_to);
  // keyframe_defer_deviation_max bounds the frames put off in a row; 0 puts none off.
  options.keyframe_defer_deviation_max = 0;
  EXPECT_TRUE(track_frames(scene, options, frames).keyframe(jump_to));
}

// An early keyframe (one the frame needs before max_frames_between_keyframes) waits
// min_frames_between_keyframes after the last one for a moving camera and
// min_frames_between_slow_keyframes for a slow one: the same walk, seen as moving (thresholds 0)
// and as slow (thresholds out of reach).
TEST(Tracker, EarlyKeyframesWaitLongerForASlowCamera) {
  SyntheticSceneOptions o;
  o.frames = 30;
  const SyntheticRgbdScene scene(o);
  std::vector<int> all(static_cast<std::size_t>(scene.size()));
  std::iota(all.begin(), all.end(), 0);
  auto smallest_gap = [&](double threshold) {
    TrackingOptions options;
    options.early_keyframe_rotation_deg = threshold;
    options.early_keyframe_translation_m = threshold;
    options.min_frames_between_slow_keyframes = 12;
    const std::vector<int> made = track_frames(scene, options, all).keyframes;
    int gap = scene.size();
    for (std::size_t k = 1; k < made.size(); ++k)
      gap = std::min(gap, made[k] - made[k - 1]);
    return gap;
  };
  // The walk needs keyframes early: the moving camera gets them 4 frames apart, the slow one 12.
  EXPECT_EQ(smallest_gap(0.0), 4);
  EXPECT_EQ(smallest_gap(1e9), 12);
}

// The constant-velocity model over another interval than the one measured: a steady twist, so
// three intervals' motion is the one interval's motion three times over.
TEST(MotionModel, ScalesTheMotionToTheFrameInterval) {
  Vector6d twist;
  twist << 0.01, -0.02, 0.03, 0.02, -0.01, 0.015;
  const SE3 one = SE3::exp(twist);
  const double interval = 1.0 / 30.0;
  const auto same = [](const SE3& a, const SE3& b) {
    return translation_distance(a, b) < 1e-12 && rotation_distance(a, b) < 1e-12;
  };
  EXPECT_TRUE(same(scale_motion(one, interval, 3 * interval), one * one * one));
  EXPECT_TRUE(same(scale_motion(one, 2 * interval, interval), SE3::exp(0.5 * twist)));
  // Recorded timestamps' jitter (TUM fr1: 27-40 ms) keeps the motion as measured, bit for bit.
  for (const double ratio : {1.46, 0.7}) {
    const SE3 jittered = scale_motion(one, interval, ratio * interval);
    EXPECT_EQ(jittered.translation(), one.translation());
    EXPECT_EQ(jittered.so3().matrix(), one.so3().matrix());
  }
  // A long gap is capped at five intervals; no interval, no scaling.
  EXPECT_TRUE(same(scale_motion(one, interval, 30 * interval), SE3::exp(5.0 * twist)));
  EXPECT_TRUE(same(scale_motion(one, 0.0, interval), one));
  EXPECT_TRUE(same(scale_motion(one, interval, -interval), one));
}

TEST(Tracker, WithoutASinkLocalizesInAFixedMapAndLeavesItAsItWas) {
  SyntheticSceneOptions scene_options;
  scene_options.frames = 60;
  const SyntheticRgbdScene scene(scene_options);
  map::SharedMap shared;
  Trajectory truth, mapped;
  {
    mapping::LocalMapper mapper(shared, vocabulary(), nullptr, 0.0, {});
    mapper.start();
    TrackingOptions options;
    options.wait_for_sink = true;
    Tracker mapping_tracker = make_tracker(shared, &mapper, scene, options);
    for (int i = 0; i < 40; ++i) {
      const SyntheticFrame f = scene.frame(i);
      const auto r = mapping_tracker.track(f.color, f.depth, f.timestamp);
      ASSERT_EQ(r.state, TrackingState::kOk) << "frame " << i;
      truth.push_back({f.timestamp, f.world_from_cam});
      mapped.push_back({f.timestamp, r.cam_from_world.inverse()});
    }
    mapper.stop();
  }
  // The map's frame in the scene's: from the mapping run.
  const Sim3 truth_from_map = eval::compute_ate(truth, mapped).gt_from_est;
  const std::size_t keyframes = shared.map.keyframe_count(), points = shared.map.point_count();

  // Localization starts cold in the middle of the mapped walk (relocalization) and follows the
  // camera on, including 20 frames past the end of the mapped part.
  Tracker localizer = make_tracker(shared, nullptr, scene);
  EXPECT_EQ(localizer.state(), TrackingState::kLost);
  double worst = 0.0;
  for (int i = 20; i < 60; ++i) {
    const SyntheticFrame f = scene.frame(i);
    const auto r = localizer.track(f.color, f.depth, f.timestamp);
    ASSERT_EQ(r.state, TrackingState::kOk) << "frame " << i;
    EXPECT_EQ(r.relocalized, i == 20) << "frame " << i;
    EXPECT_FALSE(r.keyframe);
    const SE3 world_from_cam = truth_from_map.to_se3() * r.cam_from_world.inverse();
    worst = std::max(worst, translation_distance(world_from_cam, f.world_from_cam));
  }
  EXPECT_LT(worst, 0.01);
  EXPECT_EQ(shared.map.keyframe_count(), keyframes);
  EXPECT_EQ(shared.map.point_count(), points);
  EXPECT_EQ(localizer.relocalizations(), 1);
}

}  // namespace
}  // namespace coloc::slam::tracking
