// coloc localize: localization only in a saved map (slam/localize) over a recorded sequence,
// as fast as possible or paced as a live camera (--realtime: frames arrive at their timestamps,
// the localizer drops the ones it cannot take), streaming every localized pose over OSC
// (/coloc/pose to --publish targets) and answering /coloc/get_pose with the latest one.
// coloc bench localize: ms per frame by stage and the cold-start relocalization rate.

#include <spdlog/spdlog.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <opencv2/core.hpp>
#include <optional>
#include <random>
#include <sstream>
#include <thread>

#include "Examples/coloc/camera_source.hpp"
#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/slam_inputs.hpp"
#include "Examples/coloc/verbs.hpp"
#include "Examples/coloc/view_session.hpp"
#include "fusion/osc_node.hpp"
#include "registration/align/scan_cloud.hpp"
#include "slam/core/atomic_file.hpp"
#include "slam/core/error.hpp"
#include "slam/core/input_file.hpp"
#include "slam/core/progress.hpp"
#include "slam/core/rigid.hpp"
#include "slam/core/row_progress.hpp"
#include "slam/core/timing.hpp"
#include "slam/core/yaml_text.hpp"
#include "slam/dataset/sequence.hpp"
#include "slam/eval/trajectory_error.hpp"
#include "slam/localize/frame_pacer.hpp"
#include "slam/localize/localizer.hpp"
#include "slam/settings/opencv_matrix.hpp"

namespace coloc::cli {
namespace {

namespace fs = std::filesystem;
using slam::localize::LocalizationResult;
using slam::localize::LocalizationState;
using slam::localize::Localizer;

struct LocalizeArgs {
  fs::path map, sequence, config, vocabulary, trajectory;
  fs::path gt_from_map;  // TUM file whose first pose maps the map's frame into the ground truth's
  fs::path head;         // YAML with cam_from_head: publish world_from_head instead of _cam
  std::vector<std::string> publish;
  int listen = -1;  // -1: any free port
  std::string bind = "127.0.0.1";
  bool broadcast = false;
  bool realtime = false;
  bool json = false;
  std::size_t start = 0;   // first frame
  std::size_t frames = 0;  // 0 = to the end
  int repeat = 1;          // replay the frames this often (memory over long sessions)
  double linger = 0.0;     // seconds to keep answering /coloc/get_pose after the last frame
  std::string camera;      // live input instead of --sequence (auto, /dev/videoN, replay:DIR)
  fs::path calibration;
  std::string mode;
  double seconds = 0.0;
  int odometry_frames = -1;  // -1: the localizer's default bridge
  fs::path scan;             // anchor the poses to this scan (the map must be registered to it)
  double scan_voxel = 0.01;  // metres: the scan thinned to this grid as it is read
  // bench
  ViewArgs view;  // --view: live in the browser
  int runs = 1;
  int cold_starts = 50;
  std::uint64_t seed = 1;
  int every = 1;  // bench: every Nth frame of the sequence is read
};

// cam_from_head (4x4, OpenCV YAML key `cam_from_head`, or `cam_from_headset` as the twin's
// headset/calibration.yaml has it): the camera's mounting on the headset.
SE3 read_cam_from_head_text(const fs::path& path) {
  // Through the YAML guard (OpenCV's reader can loop forever on some malformed input).
  const std::string text = read_yaml_text(path, "cam-from-head file");
  cv::FileStorage file;
  try {
    file.open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY);
  } catch (const cv::Exception& e) {
    throw Error("not a readable YAML file (" + e.err + ")", {.file = path.string()});
  }
  if (!file.isOpened()) throw Error("cannot open the calibration file", {.file = path.string()});
  const char* key = file["cam_from_head"].empty() ? "cam_from_headset" : "cam_from_head";
  // NaN, a scaled or sheared rotation or a bad last row would put NaN or a wrong pose on the
  // wire: read_rigid_matrix refuses them (slam/core's rigid check), naming the file and key.
  const auto t = settings::read_rigid_matrix(file[key], {.file = path.string(), .field = key});
  if (!t) {
    throw Error("expected a 4x4 matrix under cam_from_head (or cam_from_headset)",
                {.file = path.string(), .field = key});
  }
  return *t;
}

SE3 read_cam_from_head(const fs::path& path) {
  return read_naming_file(path, "cam-from-head file",
                          [&] { return read_cam_from_head_text(path); });
}

// What the localizer runs on: the map, the settings and the sequence read with them.
struct LocalizeInputs {
  slam::bow::Vocabulary vocabulary;
  std::unique_ptr<slam::localize::LocalizationMap> map;
  settings::Settings settings;
  std::unique_ptr<dataset::Sequence> sequence;  // null with --camera
  std::optional<LiveInput> live;
};

// --config, else the settings the map was built with (saved in its metadata), else the file
// shipped for the sequence's format.
settings::Settings choose_settings(const LocalizeArgs& args,
                                   const slam::localize::LocalizationMap& map) {
  if (!args.config.empty()) return settings::load_settings(args.config);
  if (map.metadata.settings.empty())
    return settings::load_settings(default_config_for(args.sequence));
  return slam::localize::settings_saved_in(map, args.map);
}

LocalizeInputs load_inputs(const LocalizeArgs& args) {
  LocalizeInputs in{load_vocabulary(args.vocabulary), nullptr, {}, nullptr, std::nullopt};
  in.map = slam::localize::load_localization_map(args.map, in.vocabulary);
  if (!args.camera.empty()) {
    // The live camera's own calibration (or --config) describes its frames, not the map's.
    in.live = open_live_input(args.camera, args.calibration, args.mode, args.config,
                              fs::temp_directory_path() /
                                  ("coloc_localize_camera_" + std::to_string(getpid()) + ".yaml"));
    in.settings = in.live->settings;
    return in;
  }
  in.settings = choose_settings(args, *in.map);
  in.sequence = open_sequence_for(args.sequence, in.settings);
  if (args.start >= in.sequence->size())
    throw Error("--start " + std::to_string(args.start) + " is past the sequence's " +
                    std::to_string(in.sequence->size()) + " frames",
                {.file = args.sequence.string(), .field = "--start"});
  return in;
}

std::optional<dataset::Frame> read_frame(const dataset::Sequence& sequence, std::size_t i) {
  try {
    return sequence.frame(i);
  } catch (const Error& e) {
    // One unreadable image must not stop a live session: skip it, say which, go on.
    spdlog::warn("frame {} skipped: {}", i, e.what());
    return std::nullopt;
  }
}

struct SessionTotals {
  std::uint64_t skipped = 0, dropped = 0, published = 0;
  double inliers_sum = 0.0, rms_sum = 0.0;
  Trajectory trajectory;  // localized poses (first replay only)
};

// Feeds frames [start, end) `repeat` times, paced or not; every result goes to `sink`.
template <typename Sink>
void replay(const LocalizeArgs& args, const dataset::Sequence& sequence, std::size_t end,
            SessionTotals& totals, Sink&& sink) {
  const std::size_t n = end - args.start;
  const double first = sequence.timestamp(args.start);
  // Replays continue the clock (period = span + one frame) so time never runs backwards.
  const double span = sequence.timestamp(end - 1) - first;
  const double period = span + (n > 1 ? span / static_cast<double>(n - 1) : 0.033);
  std::vector<double> times;
  times.reserve(n * static_cast<std::size_t>(args.repeat));
  for (int r = 0; r < args.repeat; ++r)
    for (std::size_t i = 0; i < n; ++i)
      times.push_back(sequence.timestamp(args.start + i) + r * period);
  slam::localize::FramePacer pacer(times);
  Progress progress("localize", times.size(), args.json);
  const Stopwatch clock;
  std::size_t done = 0;
  while (true) {
    std::optional<slam::localize::PacedFrame> f;
    if (args.realtime) {
      f = pacer.next(clock.elapsed_seconds());
    } else if (done < times.size()) {
      f = slam::localize::PacedFrame{done, 0.0, 0};
    }
    if (!f) break;
    done = f->index + 1;
    if (f->wait_s > 0.0) std::this_thread::sleep_for(std::chrono::duration<double>(f->wait_s));
    progress.set(done);
    const std::size_t index = args.start + f->index % n;
    const auto frame = read_frame(sequence, index);
    if (!frame) {
      ++totals.skipped;
      continue;
    }
    sink(*frame, times[f->index], f->index < n);
  }
  progress.finish();
  if (args.realtime) totals.dropped = pacer.dropped();
}

// The live camera's frames until it stops, or the sequence's replayed; each goes to `sink`.
template <typename Sink>
void feed_frames(const LocalizeArgs& args, LocalizeInputs& in, SessionTotals& totals, Sink&& sink) {
  if (in.live) {
    const SignalStop signals(*in.live->camera);
    const auto frames = live_frames(*in.live->camera, args.seconds);
    while (auto f = frames->next())
      sink(*f, f->timestamp, true);
    // As with --realtime, "dropped" counts the frames the localizer was too busy to take.
    totals.dropped = end_live(*in.live->camera).queue_drops;
    return;
  }
  const dataset::Sequence& sequence = *in.sequence;
  const std::size_t end =
      args.frames == 0 ? sequence.size() : std::min(sequence.size(), args.start + args.frames);
  replay(args, sequence, end, totals, sink);
}

std::optional<eval::AteResult> ate(const dataset::Sequence& sequence, const Trajectory& t,
                                   eval::Alignment alignment) {
  if (sequence.ground_truth().empty() || t.size() < 3) return std::nullopt;
  try {
    return eval::compute_ate(sequence.ground_truth(), t, {.alignment = alignment});
  } catch (const Error& e) {
    spdlog::warn("ATE not computed: {}", e.what());
    return std::nullopt;
  }
}

void write_trajectory(const fs::path& path, const Trajectory& trajectory) {
  write_tum_trajectory(path, trajectory);  // atomic (core AtomicOutput)
}

fusion::PoseServerOptions server_options(const LocalizeArgs& args) {
  fusion::PoseServerOptions osc;
  osc.endpoint.bind_address = args.bind;
  osc.endpoint.port = std::max(args.listen, 0);
  osc.endpoint.broadcast = args.broadcast;
  osc.targets = args.publish;
  return osc;
}

// The localized trajectory moved by a known (not fitted) transform into the ground truth's
// frame: the first pose of the --gt-from-map file; unchanged without one.
Trajectory in_ground_truth_frame(Trajectory t, const fs::path& gt_from_map) {
  if (gt_from_map.empty()) return t;
  const Trajectory file = read_tum_trajectory(gt_from_map);
  if (file.empty()) throw Error("no pose in the file", {.file = gt_from_map.string()});
  for (auto& p : t)
    p.world_from_cam = file.front().world_from_cam * p.world_from_cam;
  return t;
}

// The end-of-run summary (text or --json): counts, times, OSC, accuracy against the ground truth.
void print_summary(const LocalizeArgs& args, const LocalizeInputs& in,
                   const slam::localize::LocalizerStats& s, const SessionTotals& totals,
                   const fusion::PoseServer& server, const char* published_name) {
  const double localized = std::max<double>(1.0, static_cast<double>(s.localized));
  std::optional<eval::AteResult> aligned, unaligned;
  if (in.sequence) {  // a live camera has no ground truth
    aligned = ate(*in.sequence, totals.trajectory, eval::Alignment::kSE3);
    // Without alignment: in the map's frame, or moved by a known (not fitted) transform into the
    // ground truth's frame (a twin map: the mapped walk's scan_from_sequence_start.txt).
    unaligned = ate(*in.sequence, in_ground_truth_frame(totals.trajectory, args.gt_from_map),
                    eval::Alignment::kNone);
  }
  const fusion::OscStats osc_stats = server.stats();
  const std::uint64_t bad_packets = osc_stats.oversized + osc_stats.malformed +
                                    osc_stats.unknown_address + osc_stats.wrong_types +
                                    osc_stats.invalid_values;
  if (args.json) {
    print_json({{"frames", s.frames},
                {"published_pose", published_name},
                {"localized", s.localized},
                {"bridged", s.bridged},
                {"lost", s.lost},
                {"relocalizations", s.relocalizations},
                {"anchored", s.anchored},
                {"dropped", totals.dropped},
                {"skipped", totals.skipped},
                {"ms_per_frame_median", s.total_ms.quantile(0.5)},
                {"ms_per_frame_p99", s.total_ms.quantile(0.99)},
                {"ms_per_frame_max", s.total_ms.max()},
                {"anchor_ms_median", s.anchor_ms.quantile(0.5)},
                {"first_localized_frame", s.first_localized_frame},
                {"ms_to_first_pose", s.ms_to_first_pose},
                {"inliers_mean", totals.inliers_sum / localized},
                {"reprojection_rms_px_mean", totals.rms_sum / localized},
                {"frame", in.map->metadata.frame_name},
                {"map_keyframes", in.map->keyframes()},
                {"map_points", in.map->points()},
                {"osc_port", server.port()},
                {"published", totals.published},
                {"requests_answered", server.requests_answered()},
                {"osc_bad_packets", bad_packets},
                {"ate_rmse_m", aligned ? Json(aligned->translation.rmse) : Json()},
                {"ate_unaligned_rmse_m", unaligned ? Json(unaligned->translation.rmse) : Json()}});
    return;
  }
  std::cout << "frames " << s.frames << ", localized " << s.localized
            << (s.bridged ? ", bridged by odometry " + std::to_string(s.bridged) : "") << ", lost "
            << s.lost << ", relocalizations " << s.relocalizations << ", dropped " << totals.dropped
            << (totals.skipped ? ", skipped (unreadable) " + std::to_string(totals.skipped) : "")
            << "\nms/frame: median " << s.total_ms.quantile(0.5) << ", p99 "
            << s.total_ms.quantile(0.99) << ", max " << s.total_ms.max() << "\nfirst pose at frame "
            << s.first_localized_frame << " after " << s.ms_to_first_pose << " ms; inliers mean "
            << totals.inliers_sum / localized << ", reprojection RMS mean "
            << totals.rms_sum / localized << " px"
            << "\nOSC poses " << published_name << " in the map's frame '"
            << in.map->metadata.frame_name << "'; OSC port " << server.port() << ", "
            << totals.published << " sent, " << server.requests_answered() << " requests answered, "
            << bad_packets << " bad packets dropped\n";
  if (aligned && unaligned)
    std::cout << "ATE RMSE vs ground truth: " << unaligned->translation.rmse
              << " m without alignment"
              << (args.gt_from_map.empty() ? " (map frame)" : " (map frame moved by --gt-from-map)")
              << ", " << aligned->translation.rmse << " m after SE3 alignment\n";
}

// The scan as an anchor for the localized poses: read once, thinned as it streams in.
std::shared_ptr<const slam::localize::ScanAnchor> load_scan_anchor(
    const LocalizeArgs& args, const slam::localize::LocalizationMap& map) {
  if (map.metadata.frame_name != "scan")
    throw Error(
        "--scan needs a map registered to the scan (coloc register); this map's frame is '" +
            map.metadata.frame_name + "'",
        {.file = args.map.string(), .field = "--scan"});
  registration::align::ScanCloudOptions o;
  o.voxel_size = args.scan_voxel;
  registration::align::ScanCloudStats stats;
  RowProgress progress("reading the scan", args.json);
  const Stopwatch watch;
  registration::render::PointCloud cloud =
      registration::align::load_scan_cloud(args.scan, o, &stats, progress.callback());
  progress.finish();
  auto anchor = std::make_shared<const slam::localize::ScanAnchor>(cloud.points);
  spdlog::info("scan anchor: {} ({} points read, {} kept), {} fine surfels, {:.0f} MB, {:.0f} ms",
               args.scan.string(), stats.points_read, stats.points_kept,
               anchor->grid().surfels(slam::localize::SurfaceGrid::Resolution::kFine),
               anchor->grid().bytes() / 1e6, watch.elapsed_ms());
  return anchor;
}

// What can be refused before any work: the input choice and an unwritable output.
void check_before_run(const LocalizeArgs& args) {
  std::optional<AtomicFile> probe;
  if (!args.trajectory.empty()) probe.emplace(args.trajectory);
  probe.reset();
  if (args.sequence.empty() == args.camera.empty())
    throw CLI::ValidationError(
        "give one of --sequence DIR or --camera auto|/dev/videoN|replay:DIR");
}

void run_localize(const LocalizeArgs& args) {
  check_before_run(args);
  if (!args.camera.empty()) block_stop_signals();
  LocalizeInputs in = load_inputs(args);

  std::optional<fusion::PoseServer> server;
  server.emplace(server_options(args));
  server->start();
  spdlog::info("localize: map {} ({} keyframes, {} points, frame '{}'), OSC on {}:{} -> {} targets",
               args.map.string(), in.map->keyframes(), in.map->points(),
               in.map->metadata.frame_name, args.bind, server->port(), args.publish.size());

  // Published poses: world_from_head when the headset mounting is given, else world_from_cam.
  const SE3 cam_from_published = args.head.empty() ? SE3() : read_cam_from_head(args.head);
  const char* published_name = args.head.empty() ? "world_from_cam" : "world_from_head";
  slam::localize::LocalizerOptions options = slam::localize::options_from_settings(in.settings);
  if (args.odometry_frames >= 0) options.odometry.max_frames = args.odometry_frames;
  Localizer localizer(*in.map, in.vocabulary, in.settings, options);
  if (!args.scan.empty()) localizer.anchor_to_scan(load_scan_anchor(args, *in.map));
  // A viewer that cannot start (port in use) is a warning: localization goes on without it.
  std::unique_ptr<slam::view::ViewServer> view_server;
  std::unique_ptr<LiveLocalizationView> view;
  if (args.view.enabled) view_server = start_view_server(args.view, {}, false);
  if (view_server)
    view = std::make_unique<LiveLocalizationView>(*view_server, args.view, in.map->shared.map,
                                                  in.map->shared.mutex, in.map->metadata.frame_name,
                                                  args.sequence);
  std::uint64_t frame_index = 0;
  SessionTotals totals;
  std::int32_t sequence_number = 0;
  SE3 last_pose;
  auto sink = [&](const dataset::Frame& frame, double time, bool first_replay) {
    const cv::Mat image = dataset::to_camera_order(frame.color, in.settings.rgb_order);
    LocalizationResult r;
    try {
      r = localizer.localize(image, frame.depth, time);
    } catch (const Error& e) {
      // A frame that does not fit the camera is skipped and named, as unreadable ones are.
      spdlog::warn("frame {} skipped ({}): {}", frame.index, frame.color_path.string(), e.what());
      return;
    }
    if (view)
      view->offer(image, in.settings.rgb_order, frame_index, time,
                  static_cast<slam::system::ObservedState>(r.state), r.world_from_cam, r.inliers,
                  r.total_ms, localizer.last_frame());
    ++frame_index;
    if (r.state == LocalizationState::kLost) {
      server->set_latest(fusion::PoseMessage::from_pose(time, sequence_number, 0, last_pose));
      return;
    }
    last_pose = r.world_from_cam * cam_from_published;
    if (r.state != LocalizationState::kOdometry) {  // the means are of poses in the map
      totals.inliers_sum += r.inliers;
      totals.rms_sum += r.reprojection_rms_px;
    }
    server->publish(fusion::PoseMessage::from_pose(time, sequence_number++,
                                                   static_cast<std::int32_t>(r.state), last_pose));
    totals.published += args.publish.size();
    if (first_replay) totals.trajectory.push_back({time, r.world_from_cam});
  };
  feed_frames(args, in, totals, sink);
  if (args.linger > 0.0) std::this_thread::sleep_for(std::chrono::duration<double>(args.linger));
  server->stop();
  if (!args.trajectory.empty() && !totals.trajectory.empty())
    write_trajectory(args.trajectory, totals.trajectory);

  print_summary(args, in, localizer.stats(), totals, *server, published_name);
  if (view) {
    view->finish();
    linger(*view_server, view->stats(), args.view.linger_s);
  }
  if (localizer.stats().localized == 0) {
    // Nothing useful came out: a non-zero exit, not an empty trajectory and status 0.
    throw CliFailure(
        "no frame was localized in the map (a recording of another place, or the "
        "wrong settings?); no trajectory written");
  }
}

// Resident set size of this process (bytes), from /proc/self/statm; 0 when unreadable.
std::uint64_t resident_bytes() {
  std::ifstream statm("/proc/self/statm");
  std::uint64_t pages = 0, resident = 0;
  if (!(statm >> pages >> resident)) return 0;
  return resident * static_cast<std::uint64_t>(sysconf(_SC_PAGESIZE));
}

// The timed passes over `frames` (bench localize), one row each.
Json bench_runs(const LocalizeArgs& args, const LocalizeInputs& in,
                const std::vector<dataset::Frame>& frames) {
  const auto options = slam::localize::options_from_settings(in.settings);
  if (!args.json)
    std::printf("%4s %9s %9s %9s %9s %9s %9s %9s %9s %9s %9s %6s %5s %5s\n", "run", "extr_med",
                "extr_p99", "pose_med", "pose_p99", "lmap_med", "lmap_p99", "total_med",
                "total_p99", "cpu_med", "cpu_p99", "loc", "lost", "reloc");
  Json rows = Json::array();
  for (int run = 0; run < args.runs; ++run) {
    Localizer localizer(*in.map, in.vocabulary, in.settings, options);
    if (!args.scan.empty()) localizer.anchor_to_scan(load_scan_anchor(args, *in.map));
    std::vector<double> extract, pose, lmap, total, cpu;
    for (const auto& f : frames) {
      const ThreadCpuStopwatch cpu_watch;
      const LocalizationResult r = localizer.localize(f.color, f.depth, f.timestamp);
      cpu.push_back(cpu_watch.elapsed_ms());
      extract.push_back(r.extract_ms);
      pose.push_back(r.pose_ms);
      lmap.push_back(r.local_map_ms);
      total.push_back(r.total_ms);
    }
    const auto& s = localizer.stats();
    rows.push_back({{"ms_median", quantile(total, 0.5)},
                    {"ms_p99", quantile(total, 0.99)},
                    {"cpu_ms_median", quantile(cpu, 0.5)},
                    {"localized", s.localized},
                    {"lost", s.lost},
                    {"relocalizations", s.relocalizations}});
    if (args.json) continue;
    std::printf(
        "%4d %9.2f %9.2f %9.2f %9.2f %9.2f %9.2f %9.2f %9.2f %9.2f %9.2f %6llu %5llu %5llu\n",
        run + 1, quantile(extract, 0.5), quantile(extract, 0.99), quantile(pose, 0.5),
        quantile(pose, 0.99), quantile(lmap, 0.5), quantile(lmap, 0.99), quantile(total, 0.5),
        quantile(total, 0.99), quantile(cpu, 0.5), quantile(cpu, 0.99),
        static_cast<unsigned long long>(s.localized), static_cast<unsigned long long>(s.lost),
        static_cast<unsigned long long>(s.relocalizations));
  }
  if (!args.json && args.runs > 0)
    std::printf(
        "ms per frame (wall): extraction (extr), initial pose: motion model or relocalization "
        "(pose),\nlocal-map tracking (lmap), the whole localize() call (total); cpu: the calling "
        "thread's CPU time\nfor the whole call (what the frame costs on a loaded machine)\n");
  return rows;
}

// Cold starts (bench localize): a fresh localizer whose first frame is a random one of `frames`.
Json bench_cold_starts(const LocalizeArgs& args, const LocalizeInputs& in,
                       const std::vector<dataset::Frame>& frames) {
  if (args.cold_starts <= 0 || frames.empty()) return Json();
  std::mt19937_64 rng(args.seed);
  std::uniform_int_distribution<std::size_t> pick(0, frames.size() - 1);
  Localizer localizer(*in.map, in.vocabulary, in.settings,
                      slam::localize::options_from_settings(in.settings));
  std::vector<double> ms_ok, ms_all;
  int ok = 0;
  for (int k = 0; k < args.cold_starts; ++k) {
    const auto& f = frames[pick(rng)];
    localizer.reset();
    const LocalizationResult r = localizer.localize(f.color, f.depth, f.timestamp);
    ms_all.push_back(r.total_ms);
    if (r.state != LocalizationState::kLost) {
      ++ok;
      ms_ok.push_back(r.total_ms);
    }
  }
  const double median = ms_ok.empty() ? 0.0 : quantile(ms_ok, 0.5);
  const double p99 = ms_ok.empty() ? 0.0 : quantile(ms_ok, 0.99);
  if (!args.json)
    std::printf(
        "cold start (first frame anywhere, seed %llu): %d of %d localized (%.0f %%), ms to first "
        "pose median %.2f, p99 %.2f (all attempts: median %.2f)\n",
        static_cast<unsigned long long>(args.seed), ok, args.cold_starts,
        100.0 * ok / args.cold_starts, median, p99, quantile(ms_all, 0.5));
  return {{"attempts", args.cold_starts},
          {"localized", ok},
          {"ms_median", median},
          {"ms_p99", p99},
          {"ms_median_all", quantile(ms_all, 0.5)}};
}

void run_bench(const LocalizeArgs& args) {
  LocalizeInputs in{load_vocabulary(args.vocabulary), nullptr, {}, nullptr};
  const std::uint64_t rss_before = resident_bytes();
  in.map = slam::localize::load_localization_map(args.map, in.vocabulary);
  const std::uint64_t rss_after = resident_bytes();
  in.settings = choose_settings(args, *in.map);
  in.sequence = open_sequence_for(args.sequence, in.settings);
  const dataset::Sequence& sequence = *in.sequence;
  // Frames are read once, up front: the timing is the localizer's, not the PNG decoder's
  // (--every keeps a long walk's frames within memory).
  std::vector<dataset::Frame> frames;
  for (std::size_t i = 0; i < sequence.size(); i += static_cast<std::size_t>(args.every)) {
    if (auto f = read_frame(sequence, i)) {
      f->color = dataset::to_camera_order(f->color, in.settings.rgb_order);
      frames.push_back(std::move(*f));
    }
  }
  const double map_mb = static_cast<double>(rss_after - rss_before) / 1e6;
  const std::size_t keyframes = in.map->keyframes();
  if (!args.json) {
    std::printf("map %s: %zu keyframes, %zu points, resident %.1f MB (%.1f kB per keyframe)\n",
                args.map.string().c_str(), keyframes, in.map->points(), map_mb,
                1e3 * map_mb / static_cast<double>(std::max<std::size_t>(1, keyframes)));
    std::printf("sequence %s: %zu frames %dx%d (every %d)\n", args.sequence.string().c_str(),
                frames.size(), frames.empty() ? 0 : frames.front().color.cols,
                frames.empty() ? 0 : frames.front().color.rows, args.every);
  }
  const Json runs = bench_runs(args, in, frames);
  const Json cold = bench_cold_starts(args, in, frames);
  if (args.json)
    print_json({{"map_keyframes", keyframes},
                {"map_points", in.map->points()},
                {"map_resident_mb", map_mb},
                {"frames", frames.size()},
                {"every", args.every},
                {"runs", runs},
                {"cold_start", cold}});
}

void add_scan_options(CLI::App& cmd, LocalizeArgs& args) {
  cmd.add_option(
         "--scan", args.scan,
         "The scan the map is registered to (E57, PLY, PCD): each pose is anchored to it "
         "by aligning the frame's depth to the scan's surface (docs/modules/localization.md)")
      ->check(CLI::ExistingFile);
  cmd.add_option("--scan-voxel", args.scan_voxel, "With --scan: thin the scan to this grid (m)")
      ->check(CLI::Range(0.002, 0.2))
      ->capture_default_str();
}

}  // namespace

void add_localize_verb(CLI::App& app, CLI::App& bench) {
  auto args = std::make_shared<LocalizeArgs>();
  CLI::App* cmd = app.add_subcommand(
      "localize",
      "Localization only in a saved map; poses (world_from_cam, map frame) over OSC and TUM");
  cmd->add_option("--map", args->map, "Map file (coloc map --save)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--camera", args->camera,
                  "Live RealSense instead of --sequence: auto, /dev/videoN or replay:DIR");
  cmd->add_option("--calibration", args->calibration,
                  "With --camera: camera YAML instead of the factory calibration")
      ->check(CLI::ExistingFile);
  cmd->add_option("--mode", args->mode, "With --camera: depth=WxH@FPS,color=WxH@FPS");
  cmd->add_option("--seconds", args->seconds, "With --camera: stop after this long (else Ctrl-C)");
  cmd->add_option("--sequence", args->sequence, "Sequence folder (TUM, 7-Scenes, twin)")
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--config", args->config,
                  "Camera settings YAML (default: the settings saved in the map)");
  cmd->add_option("--vocabulary", args->vocabulary,
                  "BoW vocabulary (default: Vocabulary/coloc_orb_k10_L5.cvoc)");
  cmd->add_option("--trajectory", args->trajectory,
                  "Output: localized poses world_from_cam (TUM format)");
  cmd->add_option("--gt-from-map", args->gt_from_map,
                  "TUM file whose first pose maps the map's frame into the ground truth's (for "
                  "the ATE without alignment; a twin: groundtruth/scan_from_sequence_start.txt of "
                  "the mapped walk)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--cam-from-head", args->head,
                  "YAML with the 4x4 cam_from_head (or cam_from_headset) of the camera on the "
                  "headset: OSC poses become world_from_head (the trajectory file stays "
                  "world_from_cam)");  // checked by its reader: a directory or FIFO named, exit 1
  cmd->add_option("--publish", args->publish,
                  "Send every localized pose as /coloc/pose to osc.udp://HOST:PORT (repeatable)");
  cmd->add_option("--listen", args->listen,
                  "UDP port answering /coloc/get_pose (default: any free port)")
      ->check(CLI::Range(0, 65535));
  cmd->add_option("--bind", args->bind, "Address to bind (loopback unless told otherwise)")
      ->capture_default_str();
  cmd->add_flag("--broadcast", args->broadcast,
                "Allow --publish to a subnet broadcast address (SO_BROADCAST)");
  cmd->add_flag("--realtime", args->realtime,
                "Frames arrive at their timestamps; frames the localizer cannot take are dropped");
  cmd->add_option("--odometry-frames", args->odometry_frames,
                  "Outside the map, carry the pose on by visual odometry for at most this many "
                  "frames (state 3, 'odometry'; 0: report lost instead; default 150)")
      ->check(CLI::Range(0, 100000));
  add_scan_options(*cmd, *args);
  cmd->add_option("--start", args->start, "First frame (0-based)");
  cmd->add_option("--frames", args->frames, "Frames to localize (0: to the end)");
  cmd->add_option("--repeat", args->repeat, "Replay the frames this many times")
      ->check(CLI::Range(1, 100000));
  cmd->add_option("--linger", args->linger,
                  "Seconds to keep answering /coloc/get_pose after the last frame")
      ->check(CLI::Range(0.0, 3600.0));
  cmd->add_flag("--json", args->json, "Machine-readable summary");
  add_live_view_options(*cmd, args->view);
  cmd->callback([args] { run_localize(*args); });

  CLI::App* b = bench.add_subcommand(
      "localize", "Localization ms/frame by stage, cold-start relocalization, map memory");
  b->add_option("--map", args->map, "Map file")->required()->check(CLI::ExistingFile);
  b->add_option("--sequence", args->sequence, "Sequence folder")
      ->required()
      ->check(CLI::ExistingDirectory);
  b->add_option("--config", args->config, "Camera settings YAML (default: the map's)");
  b->add_option("--vocabulary", args->vocabulary, "BoW vocabulary");
  b->add_option("--runs", args->runs, "Passes over the sequence (0: cold starts only)")
      ->check(CLI::Range(0, 100));
  b->add_option("--cold-starts", args->cold_starts, "Random first frames to relocalize")
      ->check(CLI::Range(0, 100000));
  b->add_option("--seed", args->seed, "Seed of the random frames")->capture_default_str();
  b->add_option("--every", args->every, "Read every Nth frame (a long walk's frames in memory)")
      ->check(CLI::Range(1, 1000));
  b->add_flag("--json", args->json, "Machine-readable summary");
  b->callback([args] { run_bench(*args); });
}

}  // namespace coloc::cli
