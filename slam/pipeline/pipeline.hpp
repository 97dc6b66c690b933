#pragma once
// One SLAM run, as every entry point makes it (`coloc map`, the benches, `rgbd_tum`, the tests
// and library users): a System (new, or continuing a saved map), every frame tracked
// (unusable ones skipped and counted), shutdown, the global BA of the finished map (with the
// IMU when the sequence has one), and the accuracy of what came out against the ground truth.
// One function, so that every entry point gets the same map from the same input.
#include <filesystem>
#include <functional>
#include <optional>

#include "slam/bow/vocabulary.hpp"
#include "slam/core/trajectory.hpp"
#include "slam/dataset/frame_source.hpp"
#include "slam/dataset/sequence.hpp"
#include "slam/eval/trajectory_error.hpp"
#include "slam/mapping/global_ba.hpp"
#include "slam/settings/settings.hpp"
#include "slam/system/system.hpp"

namespace coloc::slam::pipeline {

// How a recording's frames meet tracking and mapping. By default back to back, with tracking
// waiting for local mapping after each keyframe (`sequential`, which the sequence overload of
// run_slam sets): a recording can wait, so which frames become keyframes does not depend on how
// busy the mapper happens to be, and every run gives the same map. `realtime` delivers them at
// their timestamps as a live camera does, and `concurrent` back to back without waiting
// (tracking runs about four times real time and the mapper's load decides the keyframes).
struct RunOptions {
  bool sequential = false;  // tracking waits for local mapping after each keyframe
  bool realtime = false;    // a sequence's frames arrive at their timestamps (dataset::paced)
  bool concurrent = false;  // a sequence's frames back to back, tracking never waiting
  // The frame source can wait (recorded frames, unpaced): in concurrent runs, tracking then lets
  // local mapping settle an unknown rolling-shutter readout first
  // (TrackingOptions::readout_settle_keyframes). Set by the sequence overload of run_slam; a
  // live camera cannot wait.
  bool source_waits = false;
  // Frames whose features are extracted ahead of tracking on a thread of their own
  // (pipeline/extract_ahead.hpp): 1 for a live camera (or frames paced as one), 8 for a
  // recording that can wait (the sequence overload of run_slam sets it); 0 extracts on the
  // tracking thread. The map is the same either way; only the wall time differs.
  std::size_t extract_ahead = 1;
  bool global_ba = true;  // of the finished map
  bool loop = true;       // loop closing
  // The global BA ties the tilt to gravity and the keyframes' relative rotations to the gyro
  // when the sequence has an IMU log and the settings place the IMU (IMU.T_b_c1); in a
  // continued map (`load`), the keyframes this recording made.
  bool imu = true;
  // With the IMU, a bench's A/B on one map: the final BA first runs without it
  // (RunResult::ate_vision), then with gravity only (ate_gravity), then with gravity and the
  // gyro, each from where the one before left the map.
  bool compare_imu = false;
  std::filesystem::path load;  // a saved map to continue (empty: a new map)
  // Called with the System before the first frame (a live viewer attaches itself), and before
  // the System is destroyed, also when the run fails (it detaches).
  std::function<void(system::System&)> on_start;
  std::function<void()> on_stop;
  // Progress bars of the map's load and of the frames on stderr (never stdout).
  bool progress = true;
};

struct RunResult {
  system::SystemSummary summary;
  Trajectory trajectory, keyframes;  // after the global BA when it ran
  std::optional<eval::AteResult> ate;
  // Every keyframe of the map (a continued map's earlier ones too) against the ground truth.
  std::optional<eval::AteResult> ate_keyframes;
  // The trajectory as tracking left it (before the global BA), and the BA's report.
  std::optional<eval::AteResult> ate_online;
  std::optional<mapping::GlobalBaReport> global_ba;
  // The same map after a global BA without the IMU, then with gravity only
  // (RunOptions::compare_imu).
  std::optional<eval::AteResult> ate_vision, ate_gravity;
  std::size_t skipped_frames = 0;  // unreadable images (named in the log)
  // Paced: frames tracking asked for a frame interval or more late, which a live camera would
  // have dropped (dataset::FrameSource::late).
  std::size_t late_frames = 0;
};

// How the sequence overload of run_slam delivers a recording's frames: "sequential",
// "concurrent" or "paced" (realtime; "paced, sequential" with both).
const char* pacing_name(const RunOptions& run);

// `finished` (optional) sees the System once the run and its global BA are done (to save it).
RunResult run_slam(const dataset::Sequence& sequence, const settings::Settings& settings,
                   const slam::bow::Vocabulary& vocabulary, const RunOptions& options,
                   const std::function<void(const system::System&)>& finished = {});
// The same over frames one after the other (a live camera: `coloc map --camera`); the ATE
// figures exist when `truth` (the sequence with ground truth) is given.
RunResult run_slam(dataset::FrameSource& frames, const dataset::Sequence* truth,
                   const settings::Settings& settings, const slam::bow::Vocabulary& vocabulary,
                   const RunOptions& options,
                   const std::function<void(const system::System&)>& finished = {});

}  // namespace coloc::slam::pipeline
