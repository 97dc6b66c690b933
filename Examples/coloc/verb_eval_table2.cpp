// coloc eval table2: the paper's Table 2 (registration/align/table2.hpp) for a map at each
// registration level, over the map's keyframes or, with --sequence, over a test walk localized
// in each map (registration/align/test_walk.hpp), as the paper evaluates. With --groundtruth (the
// twin's), also the TRUE pose errors. This file loads, runs and prints; the metrics are the
// library's.

#include <spdlog/spdlog.h>

#include <cstdio>
#include <iostream>
#include <map>
#include <memory>
#include <numbers>

#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/slam_inputs.hpp"
#include "Examples/coloc/verbs.hpp"
#include "registration/align/refine.hpp"
#include "registration/align/scan_cloud.hpp"
#include "registration/align/table2.hpp"
#include "registration/align/test_walk.hpp"
#include "slam/core/error.hpp"
#include "slam/core/row_progress.hpp"
#include "slam/core/timing.hpp"
#include "slam/core/trajectory.hpp"
#include "slam/mapdb/mapdb.hpp"

namespace coloc::cli {
namespace {

namespace fs = std::filesystem;
namespace align = registration::align;
namespace render = registration::render;

struct Table2Args {
  std::vector<std::string> maps;  // LEVEL=FILE
  fs::path scan, groundtruth, vocabulary;
  align::WalkOptions walk;  // walk.sequence empty: the map's keyframes are evaluated
  double voxel = 0.01;
  int threads = 2;
  bool json = false;
};

Json stats_json(const align::Table2Stats& s) {
  return Json{{"mean", s.mean}, {"std", s.std}, {"p50", s.p50}, {"p90", s.p90}, {"n", s.n}};
}

struct LevelResult {
  std::string level;
  fs::path file;
  std::size_t walk_frames = 0, walk_localized = 0;
  align::Table2Row row;  // views: keyframes, or sampled walk frames
  double ms = 0.0;
};

LevelResult evaluate(const std::string& level, const fs::path& file,
                     const render::PointCloud& cloud, const slam::bow::Vocabulary& vocabulary,
                     const Trajectory& truth, const Table2Args& a) {
  Stopwatch watch;
  LevelResult out;
  out.level = level;
  out.file = file;
  const slam::mapdb::LoadedMap loaded =
      slam::mapdb::load_map(file, vocabulary, {.rebuild_bow = false, .keyframe_depth = false});
  if (loaded.metadata.frame_name != "scan") {
    throw Error("the map is in frame '" + loaded.metadata.frame_name +
                    "', not the scan's: register it first (coloc register)",
                {.file = file.string(), .field = "metadata.frame_name"});
  }
  const Camera camera = slam::mapdb::camera_of(loaded, file);
  align::RefineOptions o;
  o.threads = a.threads;
  std::optional<align::LocalizedWalk> walk;
  std::vector<align::MatchView> views;
  if (!a.walk.sequence.empty()) {
    walk = align::localize_walk(file, vocabulary, a.walk);
    views = walk->views;
    out.walk_frames = walk->frames;
    out.walk_localized = walk->localized;
  } else {
    for (const auto& [id, kf] : loaded.map.keyframes())
      views.push_back({id, kf.frame.timestamp, &kf.frame.features, kf.cam_from_world()});
  }
  RowProgress progress("table2 " + level, a.json);
  const std::vector<align::KeyframeRefinement> r = align::match_views(
      views, cloud, align::ideal_camera(loaded.map, camera), o,
      [&](std::size_t done, std::size_t total) { progress.callback()(done, total); });
  progress.finish();
  out.row = align::table2_row(r, walk ? walk->trajectory : Trajectory{}, truth);
  out.ms = watch.elapsed_ms();
  return out;
}

void print_table(const std::vector<LevelResult>& rows, bool truth) {
  std::printf("%-34s", "metric");
  for (const auto& r : rows)
    std::printf(" | %-31s", r.level.c_str());
  std::printf("\n%-34s", "");
  for (std::size_t i = 0; i < rows.size(); ++i)
    std::printf(" | %7s %7s %7s %7s", "mean", "std", "P50", "P90");
  std::printf("\n");
  const auto line = [&](const char* name, align::Table2Stats align::Table2Row::*field) {
    std::printf("%-34s", name);
    for (const auto& r : rows) {
      const align::Table2Stats& s = r.row.*field;
      std::printf(" | %7.3f %7.3f %7.3f %7.3f", s.mean, s.std, s.p50, s.p90);
    }
    std::printf("\n");
  };
  line("pose angle error (deg)", &align::Table2Row::angle_deg);
  line("pose distance error (cm)", &align::Table2Row::distance_cm);
  line("2-D distance error (px)", &align::Table2Row::offset_px);
  if (truth) {
    line("TRUE pose angle error (deg)", &align::Table2Row::true_angle_deg);
    line("TRUE pose distance error (cm)", &align::Table2Row::true_distance_cm);
    line("EPnP pose vs truth (cm)", &align::Table2Row::pnp_true_distance_cm);
    std::printf("%-34s", "TRUE co-location RMSE (cm)");
    for (const auto& r : rows)
      std::printf(" | %-31.3f", r.row.true_rmse_cm);
    std::printf("\n");
  }
  if (rows.front().walk_frames > 0) {
    std::printf("%-34s", "test walk frames localized / all");
    for (const auto& r : rows)
      std::printf(" | %5zu / %-23zu", r.walk_localized, r.walk_frames);
    std::printf("\n");
  }
  std::printf("%-34s", rows.front().walk_frames > 0 ? "sampled frames matched / all, time"
                                                    : "keyframes matched / all, time");
  for (const auto& r : rows)
    std::printf(" | %5zu / %-5zu %10.1f s      ", r.row.matched, r.row.views, r.ms / 1e3);
  std::printf("\n");
}

void table2_verb(const Table2Args& a) {
  std::vector<std::pair<std::string, fs::path>> levels;
  for (const std::string& m : a.maps) {
    const auto eq = m.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == m.size())
      throw Error("expected LEVEL=FILE, got '" + m + "'", {.field = "--map"});
    levels.emplace_back(m.substr(0, eq), fs::path(m.substr(eq + 1)));
    if (!fs::is_regular_file(levels.back().second))
      throw Error("no such map file", {.file = levels.back().second.string(), .field = "--map"});
  }
  const Trajectory truth =
      a.groundtruth.empty() ? Trajectory{} : read_tum_trajectory(a.groundtruth);
  align::ScanCloudOptions co;
  co.voxel_size = a.voxel;
  RowProgress scan_progress("reading the scan", a.json);
  const render::PointCloud cloud =
      align::load_scan_cloud(a.scan, co, nullptr, scan_progress.callback());
  scan_progress.finish();
  const slam::bow::Vocabulary vocabulary = load_vocabulary(a.vocabulary);
  std::vector<LevelResult> rows;
  rows.reserve(levels.size());
  for (const auto& [level, file] : levels)
    rows.push_back(evaluate(level, file, cloud, vocabulary, truth, a));
  if (!a.json) {
    print_table(rows, !truth.empty());
    return;
  }
  Json j = Json::array();
  for (const auto& r : rows) {
    Json e{{"level", r.level},
           {"map", r.file.string()},
           {"keyframes", r.row.views},
           {"matched", r.row.matched},
           {"pose_angle_deg", stats_json(r.row.angle_deg)},
           {"pose_distance_cm", stats_json(r.row.distance_cm)},
           {"distance_2d_px", stats_json(r.row.offset_px)},
           {"seconds", r.ms / 1e3}};
    if (!truth.empty()) {
      e["true_pose_angle_deg"] = stats_json(r.row.true_angle_deg);
      e["true_pose_distance_cm"] = stats_json(r.row.true_distance_cm);
      e["epnp_vs_truth_cm"] = stats_json(r.row.pnp_true_distance_cm);
      e["true_rmse_cm"] = r.row.true_rmse_cm;
    }
    if (r.walk_frames > 0) {
      e["walk_frames"] = r.walk_frames;
      e["walk_localized"] = r.walk_localized;
    }
    j.push_back(e);
  }
  print_json(Json{{"table2", j}});
}

}  // namespace

void add_table2_verb(CLI::App& eval) {
  auto a = std::make_shared<Table2Args>();
  CLI::App& cmd = *eval.add_subcommand(
      "table2", "The paper's Table 2 for registered maps: keyframes against the scan rendering");
  cmd.add_option("--map", a->maps, "LEVEL=MAP.db (a registered map), once per level, in order")
      ->required();
  cmd.add_option("--scan", a->scan, "The scan (E57)")->required()->check(CLI::ExistingFile);
  cmd.add_option("--groundtruth", a->groundtruth,
                 "TUM trajectory of the true poses in the scan frame (the twin's): true errors")
      ->check(CLI::ExistingFile);
  cmd.add_option("--vocabulary", a->vocabulary, "BoW vocabulary the maps were built with");
  cmd.add_option("--sequence", a->walk.sequence,
                 "A test walk (sequence folder) to localize in each map and evaluate instead of "
                 "the map's keyframes")
      ->check(CLI::ExistingDirectory);
  cmd.add_option("--config", a->walk.config,
                 "Camera settings of the test walk (default: the settings saved in the map)")
      ->check(CLI::ExistingFile);
  cmd.add_option("--every", a->walk.every,
                 "Match one in this many localized frames of the walk against the scan")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  cmd.add_option("--voxel", a->voxel, "Voxel size of the scan's points (m)")->capture_default_str();
  cmd.add_option("--threads", a->threads, "Keyframes matched in parallel")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  cmd.add_flag("--json", a->json, "Machine-readable table on stdout");
  cmd.callback([a] {
    a->walk.quiet = a->json;
    table2_verb(*a);
  });
}

}  // namespace coloc::cli
