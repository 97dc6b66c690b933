// coloc register: the SLAM map registered to the laser scan by its markers (Michiels et al.
// 2024, section 4.4): rough alignment, then the global BA with the scanned marker corners held
// fixed. Writes a new map in the scan's frame whose metadata says where it came from.

#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>

#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/scan_figures.hpp"
#include "Examples/coloc/slam_inputs.hpp"
#include "Examples/coloc/verbs.hpp"
#include "markers/marker_map.hpp"
#include "registration/align/markerless.hpp"
#include "registration/align/register.hpp"
#include "registration/align/scan_cloud.hpp"
#include "registration/render/renderer.hpp"
#include "slam/core/atomic_file.hpp"
#include "slam/core/error.hpp"
#include "slam/core/input_file.hpp"
#include "slam/core/rigid.hpp"
#include "slam/core/row_progress.hpp"
#include "slam/core/timing.hpp"
#include "slam/mapdb/mapdb.hpp"

namespace coloc::cli {
namespace {

namespace fs = std::filesystem;
namespace align = registration::align;
namespace render = registration::render;

struct RegisterArgs {
  fs::path map, markers, out, scan, report, vocabulary, sequence, initial;
  bool gravity = false;
  double voxel = 0.01;
  int threads = 2;
  double refine_spacing = 0.0;
  int report_keyframes = 4;
  std::string refine_mode = "terms";
  std::string level;  // empty: "markers", or "surface" without --markers
  int min_markers = 3;
  std::vector<int> only_markers, ignore_markers;
  double inlier_threshold = 0.35;
  double marker_gate = 5.0;
  double marker_weight = 1.0;
  bool json = false;
};

void print_text(const align::RegistrationResult& r, const fs::path& out, double load_ms,
                double save_ms) {
  std::cout << "registered (" << align::level_name(r.level) << ") -> " << out.string() << "\n";
  std::cout << "  rough: " << r.rough.inliers << "/" << r.rough.markers.size()
            << " markers inliers, RMS " << r.rough.rms * 100.0 << " cm ("
            << r.ms_corners + r.ms_rough << " ms)\n";
  for (const auto& m : r.rough.markers) {
    std::cout << "    marker " << m.id << ": " << m.residual * 100.0 << " cm, " << m.keyframes
              << " keyframes, leave-one-out " << m.loo_residual * 100.0 << " cm"
              << (m.inlier ? "" : "  OUTLIER") << (m.consistent ? "" : "  INCONSISTENT (not used)")
              << "\n";
  }
  if (!r.rough.only_in_slam.empty() || !r.rough.only_in_scan.empty()) {
    std::cout << "    only in the map: " << r.rough.only_in_slam.size()
              << ", only in the scan: " << r.rough.only_in_scan.size() << "\n";
  }
  if (r.ba) {
    const auto& b = *r.ba;
    std::cout << "  markers BA: " << b.keyframes << " keyframes, " << b.points << " points, "
              << b.marker_observations << " marker corner terms, " << b.rounds << " passes, "
              << b.ms << " ms\n"
              << "    marker corners RMS " << b.initial_marker_rms_px << " -> "
              << b.final_marker_rms_px << " px, map points RMS " << b.initial_point_rms_px << " -> "
              << b.final_point_rms_px << " px, " << b.outliers << " outliers\n";
    for (const auto& m : b.markers) {
      std::cout << "    marker " << m.id << ": " << m.initial_rms_px << " -> " << m.final_rms_px
                << " px" << (m.rejected ? "  REJECTED" : "") << "\n";
    }
  }
  if (r.surface) {
    const align::SurfaceBaReport& b = *r.surface;
    std::cout << "  surface BA: " << b.depth_samples << " depth samples, " << b.marker_observations
              << " marker corner terms; median distance to the scan "
              << 1e3 * b.rounds.front().median_before_m << " -> "
              << 1e3 * b.rounds.back().median_after_m << " mm (" << r.ms_surface << " ms)\n";
  }
  if (r.refine) {
    const auto& f = *r.refine;
    std::map<std::string, int> reasons;
    for (const auto& k : f.keyframes)
      ++reasons[k.reason()];
    std::cout << "  pointcloud: " << f.accepted << "/" << f.keyframes.size()
              << " keyframes accepted (match " << f.ms_match << " ms, BA " << f.ms_ba << " ms):";
    for (const auto& [reason, count] : reasons)
      std::cout << " " << reason << " " << count;
    std::cout << "\n";
  }
  std::cout << "  load " << load_ms << " ms, save " << save_ms << " ms\n";
}

// The paper's Figure 5 for a few accepted keyframes (evenly spread over them): the scan rendered
// at the marker-registered pose with the matches drawn, and at the refined pose; blended with
// the keyframe's image when --sequence gives it.
void write_figures(const RegisterArgs& a, const align::RefineReport& f,
                   const render::PointCloud& cloud, const slam::map::Map& map, const Camera& camera,
                   const align::RefineOptions& options) {
  std::vector<const align::KeyframeRefinement*> accepted;
  for (const auto& k : f.keyframes) {
    if (k.accepted) accepted.push_back(&k);
  }
  if (accepted.empty() || a.report_keyframes <= 0) return;
  const PinholeCamera ideal = align::ideal_camera(map, camera);
  render::Renderer renderer(options.render);
  renderer.set_point_cloud(cloud);
  const std::size_t n = std::min<std::size_t>(accepted.size(), a.report_keyframes);
  for (std::size_t i = 0; i < n; ++i) {
    const align::KeyframeRefinement& k = *accepted[i * accepted.size() / n];
    cv::Mat image;
    if (!a.sequence.empty()) {
      if (auto im = sequence_image(a.sequence, k.timestamp, camera, ideal)) image = *im;
    }
    const SE3& after = map.keyframe(k.id)->cam_from_world();
    const std::string id = std::to_string(k.id.value());
    char caption[160];
    std::snprintf(caption, sizeof(caption), "keyframe %s markers: median %.1f px, %zu inliers",
                  id.c_str(), k.median_offset_px, k.inliers);
    write_png(a.report / ("keyframe_" + id + "_markers.png"),
              scan_figure(renderer.render(ideal, k.registered, render::Layer::kPoints).colour,
                          image, k.correspondences, caption));
    std::snprintf(caption, sizeof(caption), "keyframe %s pointcloud: moved %.1f cm %.2f deg",
                  id.c_str(), k.correction_m * 100.0, k.correction_deg);
    write_png(a.report / ("keyframe_" + id + "_pointcloud.png"),
              scan_figure(renderer.render(ideal, after, render::Layer::kPoints).colour, image, {},
                          caption));
  }
}

align::RegisterOptions options_of(const RegisterArgs& a) {
  align::RegisterOptions options;
  options.level = align::parse_level(a.level);
  options.rough.min_markers = a.min_markers;
  options.rough.inlier_threshold = a.inlier_threshold;
  options.ba.marker_gate_px = a.marker_gate;
  options.ba.marker_weight = a.marker_weight;
  options.refine.threads = a.threads;
  options.refine.keyframe_spacing_m = a.refine_spacing;
  options.refine.hold_fixed = a.refine_mode == "fixed";
  options.check();
  return options;
}

// The scanned markers the registration may use: --only-markers (when given) minus
// --ignore-markers (a marker known to have moved since the scan). An id the marker map does
// not hold is an error naming it: a typo must not silently register with other markers.
markers::MarkerMap select_markers(markers::MarkerMap map, const std::vector<int>& only,
                                  const std::vector<int>& ignore) {
  for (const auto* list : {&only, &ignore}) {
    for (int id : *list) {
      if (!map.markers.count(id))
        throw Error("marker " + std::to_string(id) + " is not in the scan's marker map",
                    {.field = list == &only ? "--only-markers" : "--ignore-markers"});
    }
  }
  if (!only.empty()) {
    std::erase_if(map.markers, [&](const auto& m) {
      return std::find(only.begin(), only.end(), m.first) == only.end();
    });
  }
  for (int id : ignore)
    map.markers.erase(id);
  return map;
}

// registration.json in the report directory (temporary file renamed over it).
void write_report_json(const fs::path& dir, const std::string& summary) {
  fs::create_directories(dir);
  write_file_atomically(dir / "registration.json", Json::parse(summary).dump(2) + "\n");
}

render::PointCloud read_scan_points(const RegisterArgs& a, const align::ScanCloudOptions& o,
                                    align::ScanCloudStats& stats) {
  RowProgress progress("reading the scan", a.json);
  render::PointCloud cloud = align::load_scan_cloud(a.scan, o, &stats, progress.callback());
  progress.finish();
  spdlog::info("scan: {} points read, {} kept ({} m voxels, {} stray removed), {:.0f} ms",
               stats.points_read, stats.points_kept, a.voxel, stats.points_stray, stats.ms);
  return cloud;
}

// What the registered map's metadata keeps: the registration's JSON, plus the scan's figures
// at level pointcloud.
std::string summary_of(const align::RegistrationResult& r, const RegisterArgs& a,
                       const align::ScanCloudStats& stats) {
  std::string summary = align::registration_json(r);
  if (!r.refine) return summary;
  Json j = Json::parse(summary);
  j["pointcloud"]["scan"] = {{"file", a.scan.string()},
                             {"points_read", stats.points_read},
                             {"points_kept", stats.points_kept},
                             {"points_stray", stats.points_stray},
                             {"voxel_m", a.voxel},
                             {"ms", stats.ms}};
  return j.dump();
}

// --initial: a 4x4 scan_from_map, four rows of four numbers; a rigid transform or an error
// naming the file.
SE3 read_initial(const fs::path& path) {
  check_input_file(path, "initial transform");
  std::ifstream in(path);
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      if (!(in >> m(r, c)) || !std::isfinite(m(r, c)))
        throw Error("expected a 4x4 matrix of finite numbers (scan_from_map)",
                    {.file = path.string(), .field = "row " + std::to_string(r + 1)});
  return rigid_from_matrix(m, {.file = path.string(), .field = "--initial"});
}

// Without --markers: the map's dense cloud (its keyframes' depth, from --sequence or else stored
// in the map) registered to the scan's points (registration/align/markerless.hpp), the map
// moved by the result.
void register_markerless(const RegisterArgs& a) {
  if (a.scan.empty())
    throw Error("without --markers, the map is registered by its dense cloud: give --scan",
                {.field = "--markers"});
  if (a.level != "cloud" && a.level != "surface")
    throw Error("level " + a.level + " needs --markers (without them: cloud or surface)",
                {.field = "--level"});
  { const AtomicFile probe(a.out); }
  const std::optional<SE3> initial =
      a.initial.empty() ? std::nullopt : std::optional<SE3>(read_initial(a.initial));
  const slam::bow::Vocabulary vocabulary = load_vocabulary(a.vocabulary);
  slam::mapdb::LoadedMap loaded = slam::mapdb::load_map(a.map, vocabulary, {.rebuild_bow = false});
  if (loaded.metadata.frame_name != "slam")
    throw Error("the map is already in frame '" + loaded.metadata.frame_name + "'",
                {.file = a.map.string(), .field = "metadata.frame_name"});
  // The recording when given (full resolution, colour), else the depth the map stores; a map
  // without it (schema < 4) needs --sequence, which is said before the scan is read.
  const std::optional<SlamInputs> recording =
      a.sequence.empty() ? std::nullopt
                         : std::optional<SlamInputs>(load_slam_inputs(a.sequence, {}));
  const dataset::Sequence* sequence = recording ? recording->sequence.get() : nullptr;
  align::check_depth_source(loaded.map, sequence);
  align::ScanCloudOptions cloud_options;
  cloud_options.voxel_size = a.voxel;
  align::ScanCloudStats cloud_stats;
  const render::PointCloud scan = read_scan_points(a, cloud_options, cloud_stats);
  align::MarkerlessOptions options;
  options.global.gravity = a.gravity;
  options.surface = a.level == "surface";
  const align::MarkerlessResult r = align::register_map_markerless(
      loaded.map, sequence, slam::mapdb::camera_of(loaded, a.map), scan, options, initial);
  const align::GlobalRegistrationReport& g = r.global;
  const Json summary = Json::parse(align::markerless_json(r));
  slam::mapdb::MapMetadata metadata = loaded.metadata;
  metadata.frame_name = "scan";
  metadata.frame_from_slam = r.scan_from_slam;
  metadata.registration = summary.dump();
  slam::mapdb::save_map(loaded.map, metadata, a.out);
  if (!a.report.empty()) write_report_json(a.report, summary.dump());
  if (a.json) {
    Json j = summary;
    j["out"] = a.out.string();
    print_json(j);
    return;
  }
  std::printf(
      "registered (%s, no markers) -> %s\n  map cloud: %zu points from %zu keyframes; "
      "fitness %.3f, inlier RMSE %.1f mm, overlap %.3f, runner-up fitness %.3f (%s, %.1f s)\n",
      r.surface ? "surface" : "cloud", a.out.c_str(), r.map_cloud_points, r.map_cloud.frames_used,
      g.fitness, 1e3 * g.rmse, g.overlap, g.runner_up,
      g.from_initial ? "from --initial" : "global search", g.ms / 1e3);
  if (r.surface) {
    const align::SurfaceBaRound& first = r.surface->rounds.front();
    const align::SurfaceBaRound& last = r.surface->rounds.back();
    std::printf(
        "  surface BA: %zu keyframes, %zu depth samples; median distance to the scan %.1f -> "
        "%.1f mm; reprojection RMS %.2f -> %.2f px (%.1f s)\n",
        r.surface->keyframes, r.surface->depth_samples, 1e3 * first.median_before_m,
        1e3 * last.median_after_m, r.surface->initial_point_rms_px, r.surface->final_point_rms_px,
        r.ms_surface / 1e3);
  }
}

void register_verb(const RegisterArgs& a) {
  if (a.markers.empty()) return register_markerless(a);
  if (a.level == "cloud")
    throw Error("level cloud registers without markers: leave --markers out", {.field = "--level"});
  if ((a.level == "pointcloud" || a.level == "surface") && a.scan.empty())
    throw Error("level " + a.level + " needs the scan's points", {.field = "--scan"});
  const align::RegisterOptions options = options_of(a);
  align::ScanCloudOptions cloud_options;
  cloud_options.voxel_size = a.voxel;
  cloud_options.check();  // before any work
  // An unwritable output is an error before any work (the map is written later under a
  // temporary name and renamed).
  { const AtomicFile probe(a.out); }
  const markers::MarkerMap scan =
      select_markers(markers::read_marker_map(a.markers), a.only_markers, a.ignore_markers);
  align::ScanCloudStats cloud_stats;
  const bool needs_cloud =
      options.level == align::Level::kPointcloud || options.level == align::Level::kSurface;
  const render::PointCloud cloud =
      needs_cloud ? read_scan_points(a, cloud_options, cloud_stats) : render::PointCloud{};

  Stopwatch watch;
  const slam::bow::Vocabulary vocabulary = load_vocabulary(a.vocabulary);
  RowProgress load_progress("loading the map", a.json);
  slam::mapdb::LoadedMap loaded = slam::mapdb::load_map(
      a.map, vocabulary, {.rebuild_bow = false, .progress = load_progress.callback()});
  load_progress.finish();
  const double load_ms = watch.elapsed_ms();
  if (loaded.metadata.frame_name != "slam") {
    throw Error("the map is already in frame '" + loaded.metadata.frame_name +
                    "'; register the map `coloc map` saved",
                {.file = a.map.string(), .field = "metadata.frame_name"});
  }
  const Camera camera = slam::mapdb::camera_of(loaded, a.map);
  // Level surface: the keyframes' depth samples from the recording, else from the depth the map
  // stores (without either, map points only).
  align::KeyframeDepthSamples depth;
  if (options.level == align::Level::kSurface) {
    if (!a.sequence.empty()) {
      const SlamInputs recording = load_slam_inputs(a.sequence, {});
      depth = align::keyframe_depth_samples(loaded.map, recording.sequence.get(), camera);
    } else {
      depth = align::keyframe_depth_samples(loaded.map, nullptr, camera);
    }
  }
  spdlog::info("registering {} keyframes, {} points to {} scanned markers ({})",
               loaded.map.keyframe_count(), loaded.map.point_count(), scan.markers.size(), a.level);
  RowProgress refine_progress("refining keyframes", a.json);
  const align::RegistrationResult r = align::register_map(
      loaded.map, scan, camera, options, cloud.points.empty() ? nullptr : &cloud,
      [&](std::size_t done, std::size_t total) { refine_progress.callback()(done, total); },
      &depth);
  refine_progress.finish();
  if (r.ba && !r.ba->usable()) {
    throw CliFailure("fewer than two markers survived the bundle adjustment (rejected: " +
                     std::to_string(r.ba->rejected_ids().size()) + "); the map was not written");
  }
  const std::string summary = summary_of(r, a, cloud_stats);

  slam::mapdb::MapMetadata metadata = loaded.metadata;
  metadata.frame_name = "scan";
  metadata.frame_from_slam = r.scan_from_slam;
  metadata.registration = summary;
  watch.restart();
  RowProgress save_progress("saving the map", a.json);
  slam::mapdb::save_map(loaded.map, metadata, a.out, {.progress = save_progress.callback()});
  save_progress.finish();
  const double save_ms = watch.elapsed_ms();

  if (!a.report.empty()) {
    write_report_json(a.report, summary);
    if (r.refine) write_figures(a, *r.refine, cloud, loaded.map, camera, options.refine);
  }
  if (a.json) {
    Json j = Json::parse(summary);
    j["out"] = a.out.string();
    j["load_ms"] = load_ms;
    j["save_ms"] = save_ms;
    print_json(j);
  } else {
    print_text(r, a.out, load_ms, save_ms);
  }
}

}  // namespace

void add_register_verb(CLI::App& app) {
  auto a = std::make_shared<RegisterArgs>();
  CLI::App& cmd = *app.add_subcommand(
      "register",
      "Register a SLAM map to the laser scan (by its markers, or by its dense cloud) -> map in "
      "the scan frame");
  cmd.add_option("--map", a->map, "Map database to register (frame 'slam')")
      ->required()
      ->check(CLI::ExistingFile);
  cmd.add_option("--markers", a->markers,
                 "Marker map of the scan (coloc scan-markers); without it, the map's dense cloud "
                 "is registered to the scan (--scan, --sequence)");  // checked by its reader
  cmd.add_option("--out", a->out, "Registered map database to write")->required();
  cmd.add_option(
         "--level", a->level,
         "With markers: rough (markers' rigid fit), markers (+ marker BA), pointcloud "
         "(+ refinement) or surface (+ the BA onto the scan's surface, markers kept as terms); "
         "without: cloud (the map's dense cloud onto the scan, rigid) or surface (+ the BA "
         "onto the scan's surface; the default)")
      ->check(CLI::IsMember({"rough", "markers", "pointcloud", "cloud", "surface"}));
  cmd.add_option("--scan", a->scan,
                 "The scan (E57, PLY or PCD), for levels pointcloud, cloud and surface")
      ->check(CLI::ExistingFile);
  cmd.add_option("--initial", a->initial,
                 "Level cloud: a 4x4 scan_from_map to refine from, skipping the global search")
      ->check(CLI::ExistingFile);
  cmd.add_flag("--gravity", a->gravity,
               "Level cloud: the map and the scan are both z-up (a map made with the IMU): "
               "search yaw and translation only");
  cmd.add_option("--report", a->report,
                 "Directory for the report (registration.json; level pointcloud: Figure 5 PNGs)");
  cmd.add_option("--sequence", a->sequence,
                 "The mapped sequence: the keyframes' depth (levels cloud and surface; without "
                 "it, the depth the map stores, schema 4 on) and images for the report's figures")
      ->check(CLI::ExistingDirectory);
  cmd.add_option("--report-keyframes", a->report_keyframes, "Keyframes drawn in the report")
      ->capture_default_str();
  cmd.add_option("--voxel", a->voxel, "Level pointcloud: voxel size of the scan's points (m)")
      ->capture_default_str();
  cmd.add_option("--refine-mode", a->refine_mode,
                 "Level pointcloud: accepted keyframes held fixed at their PnP poses (the paper) "
                 "or their scan matches as BA terms")
      ->check(CLI::IsMember({"fixed", "terms"}))
      ->capture_default_str();
  cmd.add_option("--refine-spacing", a->refine_spacing,
                 "Level pointcloud: match only keyframes at least this far (m) from every "
                 "matched one looking within 20 deg of the same way (0: every keyframe; a site "
                 "of 1,000+ keyframes: 1)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd.add_option("--threads", a->threads, "Level pointcloud: keyframes matched in parallel")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  cmd.add_option("--vocabulary", a->vocabulary, "BoW vocabulary the map was built with");
  cmd.add_option("--only-markers", a->only_markers,
                 "Use only these scanned markers (ids, e.g. 3,7,12)")
      ->delimiter(',');
  cmd.add_option("--ignore-markers", a->ignore_markers,
                 "Leave these scanned markers out (e.g. one known to have moved)")
      ->delimiter(',');
  cmd.add_option("--min-markers", a->min_markers, "Fewest consistent markers accepted")
      ->check(CLI::Range(2, 1000))
      ->capture_default_str();
  cmd.add_option("--inlier-threshold", a->inlier_threshold,
                 "Rough alignment: RMS corner distance of an inlier marker (m)")
      ->capture_default_str();
  cmd.add_option("--marker-gate", a->marker_gate,
                 "Marker BA: reject a marker above this RMS corner reprojection (px)")
      ->capture_default_str();
  cmd.add_option("--marker-weight", a->marker_weight,
                 "Marker BA: information of a marker corner relative to a level-0 keypoint")
      ->capture_default_str();
  cmd.add_flag("--json", a->json, "Machine-readable summary on stdout");
  cmd.callback([a] {
    // The level's default follows the input: markers, or the dense cloud without them.
    if (a->level.empty()) a->level = a->markers.empty() ? "surface" : "markers";
    register_verb(*a);
  });
}

}  // namespace coloc::cli
