#include "slam/pipeline/pipeline.hpp"

#include <spdlog/spdlog.h>

#include <memory>

#include "slam/core/error.hpp"
#include "slam/core/progress.hpp"
#include "slam/core/row_progress.hpp"
#include "slam/pipeline/extract_ahead.hpp"

namespace coloc::slam::pipeline {
namespace {

// None without ground truth, or when the poses cannot be aligned (a few keyframes on a line):
// the run itself is fine, only this figure does not exist.
std::optional<eval::AteResult> ate_of(const dataset::Sequence& sequence, const Trajectory& t) {
  if (sequence.ground_truth().empty() || t.size() < 3) return std::nullopt;
  try {
    return eval::compute_ate(sequence.ground_truth(), t);
  } catch (const Error& e) {
    spdlog::warn("no ATE over {} poses: {}", t.size(), e.what());
    return std::nullopt;
  }
}

// Keyframes mapped sequentially while an unknown readout is estimated
// (TrackingOptions::readout_settle_keyframes has the measurements behind them): 30 where the
// source can wait, 10 for a live camera or frames paced as one. The first local BAs take a few
// milliseconds, so those waits delayed no frame by a frame interval (fr1/rpy paced, 24 runs).
constexpr std::size_t kReadoutSettleKeyframes = 30;
constexpr std::size_t kLiveReadoutSettleKeyframes = 10;

// The gyro's noise figures as the settings give them (ORB-SLAM3's IMU.NoiseGyro, IMU.GyroWalk).
mapping::GyroOptions gyro_options(const settings::Settings& settings) {
  mapping::GyroOptions o;
  o.model.noise_density = settings.gyro_noise_density.value_or(o.model.noise_density);
  o.model.random_walk = settings.gyro_random_walk.value_or(o.model.random_walk);
  return o;
}

struct TrackedFrames {
  std::size_t tracked = 0, unusable = 0;
};

// Every frame of `frames` into `slam`, the features extracted ahead unless
// RunOptions::extract_ahead is 0.
TrackedFrames track_frames(system::System& slam, dataset::FrameSource& frames,
                           const settings::Settings& settings, const RunOptions& run) {
  Progress progress("slam", frames.remaining(), !run.progress);
  std::optional<ExtractAhead> ahead;
  if (run.extract_ahead > 0)
    ahead.emplace(frames, slam.feature_extraction(), settings.rgb_order, run.extract_ahead);
  auto next = [&]() -> std::optional<ExtractedFrame> {
    if (ahead) return ahead->next();
    auto frame = frames.next();
    if (!frame) return std::nullopt;
    frame->color = dataset::to_camera_order(frame->color, settings.rgb_order);
    return ExtractedFrame{std::move(*frame), std::nullopt};
  };
  TrackedFrames counts;
  while (auto item = next()) {
    progress.advance();
    const dataset::Frame& frame = item->frame;
    try {
      if (item->features)
        slam.track(frame.color, frame.depth, frame.timestamp, std::move(*item->features));
      else
        slam.track(frame.color, frame.depth, frame.timestamp);
      ++counts.tracked;
    } catch (const Error& e) {
      // Images that do not fit the camera (wrong size, depth of another size) cost one frame,
      // named, not the whole session (unreadable ones are skipped by the source).
      spdlog::warn("frame {} skipped ({}, {}): {}", frame.index, frame.color_path.string(),
                   frame.depth_path.string(), e.what());
      ++counts.unusable;
    }
  }
  progress.finish();
  return counts;  // `ahead`'s thread is joined: the source's counts are final
}

}  // namespace

const char* pacing_name(const RunOptions& run) {
  if (run.realtime) return run.sequential ? "paced, sequential" : "paced";
  return run.concurrent ? "concurrent" : "sequential";
}

RunResult run_slam(const dataset::Sequence& sequence, const settings::Settings& settings,
                   const slam::bow::Vocabulary& vocabulary, const RunOptions& run,
                   const std::function<void(const system::System&)>& finished) {
  // Decoded ahead, then paced: decoding never delays a paced frame.
  auto frames = dataset::read_ahead(dataset::frames_of(sequence));
  if (run.realtime) frames = dataset::paced(std::move(frames));
  RunOptions options = run;
  options.source_waits = !run.realtime;
  // A recording waits: tracking takes the frames extracted during a local BA in a burst.
  if (options.source_waits && options.extract_ahead > 0) options.extract_ahead = 8;
  if (options.source_waits && !run.concurrent) options.sequential = true;
  return run_slam(*frames, &sequence, settings, vocabulary, options, finished);
}

RunResult run_slam(dataset::FrameSource& frames, const dataset::Sequence* truth,
                   const settings::Settings& settings, const slam::bow::Vocabulary& vocabulary,
                   const RunOptions& run,
                   const std::function<void(const system::System&)>& finished) {
  system::SystemOptions options;
  options.tracking.wait_for_sink = run.sequential;
  options.tracking.readout_settle_keyframes =
      run.source_waits ? kReadoutSettleKeyframes : kLiveReadoutSettleKeyframes;
  options.loop.enabled = run.loop;
  std::unique_ptr<system::System> owned;
  {
    RowProgress loading("loading the map", !run.progress);
    owned = system::open_system(settings, vocabulary, options, run.load, loading.callback());
    loading.finish();
  }
  system::System& slam = *owned;
  // Runs on_stop before `owned` goes, however the run ends.
  struct Detach {
    const std::function<void()>& on_stop;
    ~Detach() {
      if (on_stop) on_stop();
    }
  } detach{run.on_stop};
  if (run.on_start) run.on_start(slam);
  RunResult r;
  const TrackedFrames counts = track_frames(slam, frames, settings, run);
  r.skipped_frames = frames.skipped() + counts.unusable;
  r.late_frames = frames.late();
  if (counts.tracked == 0)
    throw Error(r.skipped_frames > 0
                    ? "no frame of the sequence could be read or used (see the warnings)"
                    : "no frame came from the camera");
  slam.shutdown();
  auto ate_of_run = [&](const Trajectory& t) {
    return truth ? ate_of(*truth, t) : std::optional<eval::AteResult>();
  };
  r.ate_online = ate_of_run(slam.trajectory());
  if (run.global_ba) {
    // In a continued map only this recording's keyframes take the IMU (System::optimize_map).
    std::optional<mapping::GravityMeasurements> gravity;
    std::optional<mapping::GyroMeasurements> gyro;
    if (run.imu && truth && !truth->imu().empty() && settings.imu_from_cam) {
      gravity.emplace(truth->imu(), *settings.imu_from_cam, slam.trajectory());
      gyro.emplace(truth->imu(), *settings.imu_from_cam, gyro_options(settings));
    }
    if (gravity && run.compare_imu) {
      slam.optimize_map();
      r.ate_vision = ate_of_run(slam.trajectory());
      slam.optimize_map({}, {.gravity = &*gravity});
      r.ate_gravity = ate_of_run(slam.trajectory());
    }
    r.global_ba = slam.optimize_map(
        {}, {.gravity = gravity ? &*gravity : nullptr, .gyro = gyro ? &*gyro : nullptr});
  }
  r.summary = slam.summary();
  r.trajectory = slam.trajectory();
  r.keyframes = slam.keyframe_trajectory();
  r.ate = ate_of_run(r.trajectory);
  r.ate_keyframes = ate_of_run(r.keyframes);
  if (finished) finished(slam);
  return r;
}

}  // namespace coloc::slam::pipeline
