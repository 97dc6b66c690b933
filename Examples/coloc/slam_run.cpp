#include "Examples/coloc/slam_run.hpp"

#include <spdlog/spdlog.h>

#include <memory>

#include "Examples/coloc/row_progress.hpp"
#include "slam/core/error.hpp"
#include "slam/core/progress.hpp"

namespace coloc::cli {
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

}  // namespace

RunResult run_slam(const dataset::Sequence& sequence, const settings::Settings& settings,
                   const slam::bow::Vocabulary& vocabulary, const RunOptions& run,
                   const std::function<void(const slam::system::System&)>& finished) {
  slam::system::SystemOptions options;
  options.tracking.wait_for_sink = run.sequential;
  options.loop.enabled = run.loop;
  std::unique_ptr<slam::system::System> system;
  {
    RowProgress progress("loading the map", false);
    system =
        slam::system::open_system(settings, vocabulary, options, run.load, progress.callback());
    progress.finish();
  }
  slam::system::System& slam = *system;
  // Runs on_stop before `system` goes, however the run ends.
  struct Detach {
    const std::function<void()>& on_stop;
    ~Detach() {
      if (on_stop) on_stop();
    }
  } detach{run.on_stop};
  if (run.on_start) run.on_start(slam);
  Progress progress("slam", sequence.size());
  RunResult r;
  for (std::size_t i = 0; i < sequence.size(); ++i) {
    progress.set(i + 1);
    dataset::Frame frame;
    try {
      frame = sequence.frame(i);
    } catch (const Error& e) {
      // One unreadable image must not cost the whole session: skip it, say which, go on.
      spdlog::warn("frame {} skipped: {}", i, e.what());
      ++r.skipped_frames;
      continue;
    }
    try {
      slam.track(dataset::to_camera_order(frame.color, settings.rgb_order), frame.depth,
                 frame.timestamp);
    } catch (const Error& e) {
      // Images that do not fit the camera (wrong size, depth of another size): same as above.
      spdlog::warn("frame {} skipped ({}, {}): {}", i, frame.color_path.string(),
                   frame.depth_path.string(), e.what());
      ++r.skipped_frames;
    }
  }
  progress.finish();
  if (r.skipped_frames == sequence.size())
    throw Error("no frame of the sequence could be read or used (see the warnings)");
  slam.shutdown();
  r.ate_online = ate_of(sequence, slam.trajectory());
  if (run.global_ba) r.global_ba = slam.optimize_map();
  r.summary = slam.summary();
  r.trajectory = slam.trajectory();
  r.keyframes = slam.keyframe_trajectory();
  r.ate = ate_of(sequence, r.trajectory);
  r.ate_keyframes = ate_of(sequence, r.keyframes);
  if (finished) finished(slam);
  return r;
}

}  // namespace coloc::cli
