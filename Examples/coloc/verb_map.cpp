// coloc map: RGB-D SLAM over a recorded sequence (TUM, 7-Scenes, twin), a global BA of the
// finished map, and the trajectory in TUM format. coloc bench track: tracking time per frame by
// stage (median, p99), local BA time and ATE, over one or more runs (threads make runs differ;
// several runs show the spread).

#include <spdlog/spdlog.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <optional>
#include <sstream>

#include "Examples/coloc/camera_source.hpp"
#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/slam_inputs.hpp"
#include "Examples/coloc/verbs.hpp"
#include "Examples/coloc/view_session.hpp"
#include "slam/bow/vocabulary.hpp"
#include "slam/core/atomic_file.hpp"
#include "slam/core/error.hpp"
#include "slam/core/progress.hpp"
#include "slam/core/row_progress.hpp"
#include "slam/core/timing.hpp"
#include "slam/dataset/sequence.hpp"
#include "slam/dataset/slice.hpp"
#include "slam/eval/trajectory_error.hpp"
#include "slam/mapdb/mapdb.hpp"
#include "slam/pipeline/pipeline.hpp"
#include "slam/settings/settings.hpp"
#include "slam/system/system.hpp"

namespace coloc::cli {
namespace {

namespace fs = std::filesystem;

struct MapArgs {
  fs::path sequence, config, vocabulary, trajectory, keyframes;
  fs::path save;       // map file (slam/mapdb), written after the run
  fs::path load;       // map file to continue
  std::string frames;  // "A:B": only these frames of the sequence
  std::string camera;  // live input instead of --sequence (auto, /dev/videoN, replay:DIR)
  fs::path calibration;
  std::string mode;
  double seconds = 0.0;
  bool sequential = false;
  bool realtime = false;
  bool concurrent = false;
  bool no_global_ba = false;
  bool no_loop = false;
  bool no_imu = false;
  bool no_extract_ahead = false;
  bool json = false;
  int runs = 1;
  ViewArgs view;  // --view: live in the browser
};

void save_finished_map(const slam::system::System& slam, const fs::path& path, bool json) {
  RowProgress progress("saving the map", json);
  const slam::mapdb::SaveReport report = slam.save_map(path, {.progress = progress.callback()});
  progress.finish();
  spdlog::info("map saved to {}: {} keyframes, {} points, {} bytes", path.string(),
               report.keyframes, report.points, report.bytes);
}

std::vector<double> loop_correction_ms(const slam::loop::LoopStats& stats) {
  std::vector<double> ms;
  for (const auto& l : stats.loops)
    ms.push_back(l.ms);
  return ms;
}

// What `coloc map` and `coloc bench track` both start from.
struct MapInputs {
  SlamInputs slam;
  slam::bow::Vocabulary vocabulary;
};

MapInputs load_inputs(const MapArgs& args) {
  MapInputs in{load_slam_inputs(args.sequence, args.config), load_vocabulary(args.vocabulary)};
  if (!args.frames.empty()) {
    const auto [first, last] = dataset::parse_frame_range(args.frames, "--frames");
    in.slam.sequence = dataset::slice(std::move(in.slam.sequence), first, last);
  }
  return in;
}

// --camera: frames from the live camera, through the same FrameSource as a sequence's.
struct LiveResult {
  slam::pipeline::RunResult run;
  CaptureLosses lost;
};
LiveResult run_live(const MapArgs& args, const slam::pipeline::RunOptions& run,
                    const std::function<void(const slam::system::System&)>& finished) {
  block_stop_signals();
  LiveInput live = open_live_input(args.camera, args.calibration, args.mode, args.config,
                                   fs::path(args.trajectory.string() + ".camera.yaml"));
  const slam::bow::Vocabulary vocabulary = load_vocabulary(args.vocabulary);
  const SignalStop signals(*live.camera);
  const auto frames = live_frames(*live.camera, args.seconds);
  slam::pipeline::RunResult r =
      slam::pipeline::run_slam(*frames, nullptr, live.settings, vocabulary, run, finished);
  return {std::move(r), end_live(*live.camera)};
}

// `coloc map --camera`: destinations checked first, then the live run and its outputs.
void run_map_live(const MapArgs& args) {
  // Unwritable destinations are errors before the camera starts, not after the recording.
  if (!args.save.empty()) const AtomicFile probe(args.save);
  { const AtomicFile probe(args.trajectory); }
  if (!args.keyframes.empty()) const AtomicFile probe(args.keyframes);
  const LiveResult live =
      run_live(args, {.global_ba = !args.no_global_ba, .loop = !args.no_loop, .load = args.load},
               [&](const slam::system::System& slam) {
                 if (!args.save.empty()) save_finished_map(slam, args.save, args.json);
               });
  const slam::pipeline::RunResult& r = live.run;
  write_tum_trajectory(args.trajectory, r.trajectory);
  if (!args.keyframes.empty()) write_tum_trajectory(args.keyframes, r.keyframes);
  if (args.json)
    print_json({{"frames", r.summary.frames},
                {"tracked", r.summary.tracked},
                {"keyframes", r.summary.keyframes},
                {"map_points", r.summary.points},
                {"loops", r.summary.loop.loops.size()},
                {"driver_drops", live.lost.driver_drops},
                {"queue_drops", live.lost.queue_drops},
                {"unpaired", live.lost.unpaired}});
  else
    std::cout << r.summary.describe() << "\ntrajectory: " << args.trajectory.string() << "\n";
}

// The finished run on stdout: a JSON summary (--json) or the summary text with the figures.
void print_map_result(const MapArgs& args, const slam::pipeline::RunResult& r) {
  const auto& s = r.summary;
  if (args.json) {
    print_json({{"frames", s.frames},
                {"tracked", s.tracked},
                {"lost", s.lost},
                {"keyframes", s.keyframes},
                {"keyframes_made", s.keyframe_decisions.made},
                {"keyframes_deferred", s.keyframe_decisions.deferred},
                {"keyframes_refused_busy", s.keyframe_decisions.refused_busy},
                {"local_ba_runs", s.mapping.ba_runs},
                {"local_ba_aborted", s.mapping.ba_aborted},
                {"local_ba_ms_median", summarize(s.mapping.ba_ms).median},
                {"local_ba_ms_p99", summarize(s.mapping.ba_ms).p99},
                {"mapper_ms_per_keyframe_median", summarize(s.mapping.keyframe_ms).median},
                {"mapper_ms_per_keyframe_p99", summarize(s.mapping.keyframe_ms).p99},
                {"map_points", s.points},
                {"relocalizations", s.relocalizations},
                {"markers", s.mapping.markers},
                {"loops", s.loop.loops.size()},
                {"loops_rejected", s.loop.rejected},
                {"loop_correction_ms", loop_correction_ms(s.loop)},
                {"ms_per_frame_median", s.total_ms.median},
                {"ms_per_frame_p99", s.total_ms.p99},
                {"ate_rmse_m", r.ate ? Json(r.ate->translation.rmse) : Json()},
                {"ate_rmse_online_m", r.ate_online ? Json(r.ate_online->translation.rmse) : Json()},
                {"ate_keyframes_rmse_m",
                 r.ate_keyframes ? Json(r.ate_keyframes->translation.rmse) : Json()},
                {"skipped_frames", r.skipped_frames},
                {"late_frames", r.late_frames},
                {"global_ba_ms", r.global_ba ? Json(r.global_ba->ms) : Json()},
                {"global_ba_keyframes", r.global_ba ? Json(r.global_ba->keyframes) : Json()}});
  } else {
    std::cout << s.describe() << "\n";
    if (r.skipped_frames > 0)
      std::cout << "skipped " << r.skipped_frames << " unreadable frames (see the warnings)\n";
    if (r.late_frames > 0)
      std::cout << r.late_frames
                << " frames tracked a frame interval or more late (a live camera drops them)\n";
    if (r.global_ba)
      std::cout << "global BA: " << r.global_ba->keyframes << " keyframes, " << r.global_ba->points
                << " points, rms " << r.global_ba->initial_rms_px << " -> "
                << r.global_ba->final_rms_px << " px, " << r.global_ba->ms << " ms\n";
    if (r.ate_online && r.global_ba)
      std::cout << "ATE RMSE as tracked " << r.ate_online->translation.rmse << " m\n";
    if (r.ate)
      std::cout << "ATE RMSE " << r.ate->translation.rmse << " m over " << r.ate->translation.count
                << " poses\n";
    if (r.ate_keyframes)
      std::cout << "keyframe ATE RMSE " << r.ate_keyframes->translation.rmse << " m over "
                << r.ate_keyframes->translation.count << " keyframes\n";
    std::cout << "trajectory: " << args.trajectory.string() << "\n";
  }
}

void run_map(const MapArgs& given) {
  MapArgs args = given;
  if (args.sequence.empty() == args.camera.empty())
    throw CLI::ValidationError(
        "give one of --sequence DIR or --camera auto|/dev/videoN|replay:DIR");
  if (!args.camera.empty()) {
    if (args.realtime)
      throw CLI::ValidationError("--realtime paces a --sequence; a camera is live already");
    run_map_live(args);
    return;
  }
  const MapInputs in = load_inputs(args);
  // ORB-SLAM3's System.LoadAtlasFromFile / SaveAtlasToFile when the command line names none.
  if (args.load.empty()) args.load = in.slam.settings.load_map;
  if (args.save.empty()) args.save = in.slam.settings.save_map;
  // An unwritable map destination is an error before the run, not after it.
  if (!args.save.empty()) AtomicFile probe(args.save);
  { const AtomicFile probe(args.trajectory); }
  if (!args.keyframes.empty()) const AtomicFile probe(args.keyframes);
  // A viewer that cannot start (port in use) is a warning: the run goes on without it.
  std::unique_ptr<slam::view::ViewServer> server;
  std::unique_ptr<LiveSystemView> live;
  if (args.view.enabled) server = start_view_server(args.view, {}, false);
  if (server) live = std::make_unique<LiveSystemView>(*server, args.view, args.sequence);
  slam::pipeline::RunOptions run{.sequential = args.sequential,
                                 .realtime = args.realtime,
                                 .concurrent = args.concurrent,
                                 .extract_ahead = args.no_extract_ahead ? 0U : 1U,
                                 .global_ba = !args.no_global_ba,
                                 .loop = !args.no_loop,
                                 .imu = !args.no_imu,
                                 .load = args.load};
  if (live) {
    run.on_start = [&](slam::system::System& s) { live->attach(s); };
    run.on_stop = [&] { live->detach(); };
  }
  const slam::pipeline::RunResult r =
      slam::pipeline::run_slam(*in.slam.sequence, in.slam.settings, in.vocabulary, run,
                               [&](const slam::system::System& slam) {
                                 if (live) live->finish(slam);
                                 if (!args.save.empty())
                                   save_finished_map(slam, args.save, args.json);
                               });
  const auto& s = r.summary;
  if (r.trajectory.empty()) {
    // A run in which no frame tracked produced nothing to use: say so and fail, rather than
    // leave an empty trajectory and exit 0.
    std::cout << s.describe() << "\n";
    throw CliFailure("no frame of the " + std::to_string(s.frames) +
                     " was tracked: the trajectory is empty and was not written (check the "
                     "settings' camera and depth scale against the sequence)");
  }
  write_tum_trajectory(args.trajectory, r.trajectory);
  if (!args.keyframes.empty()) write_tum_trajectory(args.keyframes, r.keyframes);
  print_map_result(args, r);
  if (live) linger(*server, live->stats(), args.view.linger_s);
}

void run_bench(const MapArgs& args) {
  const MapInputs in = load_inputs(args);
  const auto& [config, settings, sequence] = in.slam;
  const auto& vocabulary = in.vocabulary;
  const slam::pipeline::RunOptions options{.sequential = args.sequential,
                                           .realtime = args.realtime,
                                           .concurrent = args.concurrent,
                                           .extract_ahead = args.no_extract_ahead ? 0U : 1U,
                                           .loop = !args.no_loop,
                                           .imu = !args.no_imu,
                                           .compare_imu = true};
  std::printf("sequence %s (%zu frames), settings %s, %s\n", args.sequence.string().c_str(),
              sequence->size(), config.string().c_str(), slam::pipeline::pacing_name(options));
  std::printf("%4s %9s %9s %9s %9s %9s %9s %9s %9s %9s %9s %7s %5s %4s %8s %8s %5s %8s %8s\n",
              "run", "extr_med", "extr_p99", "pose_med", "pose_p99", "lmap_med", "lmap_p99",
              "kf_med", "kf_p99", "total_med", "total_p99", "ba_med", "lost", "kfs", "ate_mm",
              "gba_mm", "loops", "vis_mm", "grav_mm");
  std::vector<double> ate_online, ate_final, ate_vision, ate_gravity;
  for (int run = 0; run < args.runs; ++run) {
    const slam::pipeline::RunResult r =
        slam::pipeline::run_slam(*sequence, settings, vocabulary, options);
    if (r.ate_online) ate_online.push_back(1e3 * r.ate_online->translation.rmse);
    if (r.ate) ate_final.push_back(1e3 * r.ate->translation.rmse);
    if (r.ate_vision) ate_vision.push_back(1e3 * r.ate_vision->translation.rmse);
    if (r.ate_gravity) ate_gravity.push_back(1e3 * r.ate_gravity->translation.rmse);
    const auto& s = r.summary;
    const SampleStats ba = summarize(s.mapping.ba_ms);
    std::printf(
        "%4d %9.2f %9.2f %9.2f %9.2f %9.2f %9.2f %9.2f %9.2f %9.2f %9.2f %7.1f %5zu %4zu %8.2f "
        "%8.2f %5zu %8.2f %8.2f\n",
        run + 1, s.extract_ms.median, s.extract_ms.p99, s.pose_ms.median, s.pose_ms.p99,
        s.local_map_ms.median, s.local_map_ms.p99, s.keyframe_ms.median, s.keyframe_ms.p99,
        s.total_ms.median, s.total_ms.p99, ba.median, s.lost, s.keyframes,
        r.ate_online ? 1e3 * r.ate_online->translation.rmse : -1.0,
        r.ate ? 1e3 * r.ate->translation.rmse : -1.0, s.loop.loops.size(),
        r.ate_vision ? 1e3 * r.ate_vision->translation.rmse : -1.0,
        r.ate_gravity ? 1e3 * r.ate_gravity->translation.rmse : -1.0);
  }
  std::printf(
      "ms per frame in the tracking thread: extraction (extr), initial pose (pose), local map "
      "(lmap),\n"
      "keyframe decision + creation (kf), total (all stages + locking, not the sequential runs'\n"
      "waits for the mapper); ba_med: local BA ms per keyframe;\n"
      "ate_mm: ATE RMSE of the trajectory as tracked, gba_mm: after the final global BA;\n"
      "vis_mm, grav_mm: when the sequence has an IMU log and the settings IMU.T_b_c1, the same\n"
      "map's global BA without the IMU, then with gravity only; gba_mm is then the BA with "
      "gravity\n"
      "and the gyro, each run from where the one before left the map (else -1)\n");
  // Threads make runs differ: the spread over runs is part of the result.
  auto spread = [](const char* name, const std::vector<double>& v) {
    if (v.size() < 2) return;
    const SampleStats s = summarize(v);
    std::printf("%s over %zu runs: mean %.2f, std %.2f, median %.2f, min %.2f, max %.2f mm\n", name,
                v.size(), s.mean, s.stddev, s.median, s.min, s.max);
  };
  spread("ate_mm", ate_online);
  spread("gba_mm", ate_final);
  spread("vis_mm", ate_vision);
  spread("grav_mm", ate_gravity);
}

}  // namespace

void add_map_verb(CLI::App& app, CLI::App& bench) {
  auto args = std::make_shared<MapArgs>();
  CLI::App* map = app.add_subcommand(
      "map", "RGB-D SLAM over a sequence (TUM, 7-Scenes): trajectory in TUM format");
  map->add_option("--sequence", args->sequence, "Sequence folder")->check(CLI::ExistingDirectory);
  map->add_option("--camera", args->camera,
                  "Live RealSense instead of --sequence: auto, /dev/videoN or replay:DIR");
  map->add_option("--calibration", args->calibration,
                  "With --camera: camera YAML instead of the factory calibration")
      ->check(CLI::ExistingFile);
  map->add_option("--mode", args->mode, "With --camera: depth=WxH@FPS,color=WxH@FPS");
  map->add_option("--seconds", args->seconds, "With --camera: stop after this long (else Ctrl-C)");
  map->add_option("--config", args->config,
                  "Camera settings YAML (default: shipped file for the format)");
  map->add_option("--vocabulary", args->vocabulary,
                  "BoW vocabulary (default: Vocabulary/coloc_orb_k10_L5.cvoc)");
  map->add_option("--trajectory", args->trajectory, "Output trajectory (TUM format)")->required();
  map->add_option("--keyframes", args->keyframes, "Output keyframe trajectory (TUM format)");
  map->add_option("--save", args->save, "Save the finished map to this file (SQLite map database)");
  map->add_option("--load", args->load,
                  "Continue this saved map: the sequence relocalizes into it and extends it")
      ->check(CLI::ExistingFile);
  map->add_option("--frames", args->frames,
                  "Only frames FIRST:LAST of the sequence (0-based, LAST excluded; either may be "
                  "empty)");
  map->add_flag("--sequential", args->sequential,
                "Tracking waits for local mapping after each keyframe (a recording's default)");
  CLI::Option* realtime = map->add_flag(
      "--realtime", args->realtime,
      "Frames arrive at their timestamps, as from a live camera (none dropped; tracking falls "
      "behind when slower)");
  map->add_flag("--concurrent", args->concurrent,
                "A recording's frames back to back, tracking never waiting for the mapper")
      ->excludes(realtime);
  map->add_flag("--no-global-ba", args->no_global_ba,
                "Skip the global bundle adjustment of the finished map");
  map->add_flag("--no-loop", args->no_loop, "No loop closing");
  map->add_flag("--no-extract-ahead", args->no_extract_ahead,
                "Extract each frame's features on the tracking thread (one core) instead of "
                "ahead on a thread of their own");
  map->add_flag("--no-imu", args->no_imu,
                "The global BA ignores the sequence's IMU log (see IMU.T_b_c1)");
  map->add_flag("--json", args->json, "Machine-readable summary");
  add_live_view_options(*map, args->view);
  map->callback([args] { run_map(*args); });

  CLI::App* track =
      bench.add_subcommand("track", "RGB-D tracking ms/frame by stage, local BA time, ATE");
  track->add_option("sequence", args->sequence, "Sequence folder")
      ->required()
      ->check(CLI::ExistingDirectory);
  track->add_option("--config", args->config, "Camera settings YAML");
  track->add_option("--vocabulary", args->vocabulary, "BoW vocabulary");
  track->add_option("--runs", args->runs, "Runs (spread between runs)")->check(CLI::Range(1, 100));
  track->add_flag("--sequential", args->sequential,
                  "Tracking waits for local mapping (a recording's default)");
  CLI::Option* track_realtime =
      track->add_flag("--realtime", args->realtime, "Frames arrive at their timestamps");
  track
      ->add_flag("--concurrent", args->concurrent,
                 "Frames back to back, tracking never waiting for the mapper")
      ->excludes(track_realtime);
  track->add_flag("--no-loop", args->no_loop, "No loop closing");
  track->add_flag("--no-extract-ahead", args->no_extract_ahead,
                  "Extract features on the tracking thread");
  track->add_flag("--no-imu", args->no_imu,
                  "The global BA ignores the sequence's IMU log (see IMU.T_b_c1)");
  track->callback([args] { run_bench(*args); });
}

}  // namespace coloc::cli
