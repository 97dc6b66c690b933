// coloc register: the SLAM map registered to the laser scan by its markers (Michiels et al.
// 2024, section 4.4): rough alignment, then the global BA with the scanned marker corners held
// fixed. Writes a new map in the scan's frame whose metadata says where it came from.

#include <spdlog/spdlog.h>
#include <unistd.h>

#include <fstream>
#include <iostream>
#include <memory>

#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/row_progress.hpp"
#include "Examples/coloc/slam_inputs.hpp"
#include "Examples/coloc/verbs.hpp"
#include "markers/marker_map.hpp"
#include "registration/align/register.hpp"
#include "slam/core/error.hpp"
#include "slam/core/timing.hpp"
#include "slam/mapdb/mapdb.hpp"

namespace coloc::cli {
namespace {

namespace fs = std::filesystem;
namespace align = registration::align;

struct RegisterArgs {
  fs::path map, markers, out, scan, report, vocabulary;
  std::string level = "markers";
  int min_markers = 3;
  double inlier_threshold = 0.35;
  double marker_gate = 5.0;
  double marker_weight = 1.0;
  bool json = false;
};

// Fails before any work when `out` cannot be created: a probe file next to it is written and
// removed (the map itself is later written to a temporary file and renamed over `out`).
void check_writable(const fs::path& out) {
  const fs::path dir = out.has_parent_path() ? out.parent_path() : fs::path(".");
  if (!fs::is_directory(dir))
    throw Error("the output's directory does not exist", {.file = out.string(), .field = "--out"});
  if (fs::is_directory(out))
    throw Error("the output is a directory", {.file = out.string(), .field = "--out"});
  const fs::path probe = dir / (out.filename().string() + ".probe-" + std::to_string(::getpid()));
  {
    std::ofstream f(probe);
    if (!f)
      throw Error("cannot write next to the output", {.file = out.string(), .field = "--out"});
  }
  fs::remove(probe);
}

// The camera the marker pixels are undistorted with: the map's own model, else a pinhole with
// the keyframes' intrinsics (maps saved before the camera was stored).
Camera camera_of(const slam::mapdb::LoadedMap& loaded, const fs::path& file) {
  if (loaded.metadata.camera) return *loaded.metadata.camera;
  if (loaded.geometries.empty())
    throw Error("the map has no camera", {.file = file.string(), .field = "cameras"});
  const auto& g = *loaded.geometries.front();
  PinholeCamera c;
  c.fx = g.fx;
  c.fy = g.fy;
  c.cx = g.cx;
  c.cy = g.cy;
  c.width = static_cast<int>(g.max_x);
  c.height = static_cast<int>(g.max_y);
  return c;
}

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
  std::cout << "  load " << load_ms << " ms, save " << save_ms << " ms\n";
}

void register_verb(const RegisterArgs& a) {
  if (a.level == "pointcloud") {
    throw Error("level 'pointcloud' (refinement against the scan's points) is not available yet",
                {.field = "--level"});
  }
  align::RegisterOptions options;
  options.level = align::parse_level(a.level);
  options.rough.min_markers = a.min_markers;
  options.rough.inlier_threshold = a.inlier_threshold;
  options.ba.marker_gate_px = a.marker_gate;
  options.ba.marker_weight = a.marker_weight;
  options.check();
  check_writable(a.out);
  const markers::MarkerMap scan = markers::read_marker_map(a.markers);

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
  const Camera camera = camera_of(loaded, a.map);
  spdlog::info("registering {} keyframes, {} points to {} scanned markers ({})",
               loaded.map.keyframe_count(), loaded.map.point_count(), scan.markers.size(), a.level);
  const align::RegistrationResult r = align::register_map(loaded.map, scan, camera, options);
  if (r.ba && !r.ba->usable()) {
    throw CliFailure("fewer than two markers survived the bundle adjustment (rejected: " +
                     std::to_string(r.ba->rejected_ids().size()) + "); the map was not written");
  }
  const std::string summary = align::registration_json(r);

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
    fs::create_directories(a.report);
    const fs::path file = a.report / "registration.json";
    const fs::path tmp = a.report / ("registration.json.tmp-" + std::to_string(::getpid()));
    {
      std::ofstream f(tmp);
      f << Json::parse(summary).dump(2) << "\n";
      if (!f) throw Error("cannot write the report", {.file = tmp.string()});
    }
    fs::rename(tmp, file);
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
      "register", "Register a SLAM map to the laser scan by its markers -> map in the scan frame");
  cmd.add_option("--map", a->map, "Map database to register (frame 'slam')")
      ->required()
      ->check(CLI::ExistingFile);
  cmd.add_option("--markers", a->markers, "Marker map of the scan (coloc scan-markers)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd.add_option("--out", a->out, "Registered map database to write")->required();
  cmd.add_option("--level", a->level, "rough (markers' rigid fit) or markers (+ marker BA)")
      ->check(CLI::IsMember({"rough", "markers", "pointcloud"}))
      ->capture_default_str();
  cmd.add_option("--scan", a->scan, "The scan (E57), for level pointcloud")
      ->check(CLI::ExistingFile);
  cmd.add_option("--report", a->report, "Directory for the report (registration.json)");
  cmd.add_option("--vocabulary", a->vocabulary, "BoW vocabulary the map was built with");
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
  cmd.callback([a] { register_verb(*a); });
}

}  // namespace coloc::cli
