// coloc eval table2: the paper's Table 2 (Michiels et al. 2024, section 6) for a map at each
// registration level: every keyframe's stored features matched against the scan rendered at
// the keyframe's pose (registration/align/scan_match.hpp), EPnP + RANSAC giving the pose the
// scan says the keyframe has. Metrics per keyframe: the angle (degrees) and centre distance (cm)
// between the map's pose and that pose, and the median 2-D distance (pixels) between the
// keyframe's features and the matched features of the rendering at the map's pose (RANSAC
// inliers). Each is summarized by mean, std, P50 and P90 over the keyframes that matched. With
// --sequence, the same for a test walk localized in each map (table2_walk.hpp) instead of the
// map's own keyframes, as the paper evaluates. With --groundtruth (the twin's), also the TRUE
// pose errors (of the keyframes, or of every localized frame of the walk), which the paper could
// not measure.

#include <spdlog/spdlog.h>

#include <cstdio>
#include <iostream>
#include <map>
#include <memory>
#include <numbers>

#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/row_progress.hpp"
#include "Examples/coloc/slam_inputs.hpp"
#include "Examples/coloc/table2_walk.hpp"
#include "Examples/coloc/verbs.hpp"
#include "registration/align/refine.hpp"
#include "registration/align/scan_cloud.hpp"
#include "slam/core/error.hpp"
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
  WalkOptions walk;  // walk.sequence empty: the map's keyframes are evaluated
  double voxel = 0.01;
  int threads = 2;
  bool json = false;
};

struct Stats {
  double mean = 0.0, std = 0.0, p50 = 0.0, p90 = 0.0;
  std::size_t n = 0;
};

// The paper's columns: mean, population std, P50, P90 (numpy's interpolated quantiles).
Stats stats_of(const std::vector<double>& v) {
  Stats s;
  s.n = v.size();
  if (v.empty()) return s;
  const SampleStats summary = summarize(v);
  s.mean = summary.mean;
  s.std = summary.stddev;
  s.p50 = summary.median;
  s.p90 = quantile(v, 0.9);
  return s;
}

Json stats_json(const Stats& s) {
  return Json{{"mean", s.mean}, {"std", s.std}, {"p50", s.p50}, {"p90", s.p90}, {"n", s.n}};
}

struct LevelResult {
  std::string level;
  fs::path file;
  std::size_t keyframes = 0, matched = 0;  // views (keyframes or sampled walk frames)
  std::size_t walk_frames = 0, walk_localized = 0;
  // TRUE co-location error (RMSE of the camera centres, no alignment) of the keyframes or of
  // every localized frame of the walk.
  double true_rmse_cm = 0.0;
  Stats angle_deg, distance_cm, offset_px;
  Stats true_angle_deg, true_distance_cm, pnp_true_distance_cm;
  double ms = 0.0;
};

// The views' times (and registered poses), for associating them with the ground truth.
Trajectory views_trajectory(const std::vector<align::KeyframeRefinement>& r) {
  Trajectory t;
  for (const auto& k : r)
    t.push_back({k.timestamp, k.registered.inverse()});
  return t;
}

LevelResult evaluate(const std::string& level, const fs::path& file,
                     const render::PointCloud& cloud, const slam::bow::Vocabulary& vocabulary,
                     const Trajectory& truth, const Table2Args& a) {
  Stopwatch watch;
  LevelResult out;
  out.level = level;
  out.file = file;
  const slam::mapdb::LoadedMap loaded =
      slam::mapdb::load_map(file, vocabulary, {.rebuild_bow = false});
  if (loaded.metadata.frame_name != "scan") {
    throw Error("the map is in frame '" + loaded.metadata.frame_name +
                    "', not the scan's: register it first (coloc register)",
                {.file = file.string(), .field = "metadata.frame_name"});
  }
  const Camera camera = slam::mapdb::camera_of(loaded, file);
  align::RefineOptions o;
  o.threads = a.threads;
  std::optional<LocalizedWalk> walk;
  std::vector<align::MatchView> views;
  if (!a.walk.sequence.empty()) {
    walk = localize_walk(file, vocabulary, a.walk);
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
  out.keyframes = r.size();
  std::vector<double> angle, dist, offset, t_angle, t_dist, pnp_dist;
  for (const auto& k : r) {
    if (!k.accepted) continue;
    ++out.matched;
    angle.push_back(k.correction_deg);
    dist.push_back(k.correction_m * 100.0);
    offset.push_back(k.median_offset_px);
  }
  if (!truth.empty()) {
    Trajectory estimated;
    if (walk) {
      estimated = walk->trajectory;
    } else {
      for (const auto& k : r)
        estimated.push_back({k.timestamp, k.registered.inverse()});
    }
    double sum_sq = 0.0;
    for (const auto& [i, j] : associate_by_time(estimated, truth, 1e-3)) {
      const SE3 cam_from_world = estimated[i].world_from_cam.inverse();
      const SE3 true_cam_from_world = truth[j].world_from_cam.inverse();
      t_angle.push_back(align::pose_angle_deg(cam_from_world, true_cam_from_world));
      t_dist.push_back(align::pose_distance_m(cam_from_world, true_cam_from_world) * 100.0);
      sum_sq += t_dist.back() * t_dist.back();
    }
    if (!t_dist.empty()) out.true_rmse_cm = std::sqrt(sum_sq / double(t_dist.size()));
    for (const auto& [i, j] : associate_by_time(views_trajectory(r), truth, 1e-3)) {
      if (r[i].accepted)
        pnp_dist.push_back(align::pose_distance_m(r[i].pnp, truth[j].world_from_cam.inverse()) *
                           100.0);
    }
  }
  out.angle_deg = stats_of(angle);
  out.distance_cm = stats_of(dist);
  out.offset_px = stats_of(offset);
  out.true_angle_deg = stats_of(t_angle);
  out.true_distance_cm = stats_of(t_dist);
  out.pnp_true_distance_cm = stats_of(pnp_dist);
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
  const auto line = [&](const char* name, Stats LevelResult::*field) {
    std::printf("%-34s", name);
    for (const auto& r : rows) {
      const Stats& s = r.*field;
      std::printf(" | %7.3f %7.3f %7.3f %7.3f", s.mean, s.std, s.p50, s.p90);
    }
    std::printf("\n");
  };
  line("pose angle error (deg)", &LevelResult::angle_deg);
  line("pose distance error (cm)", &LevelResult::distance_cm);
  line("2-D distance error (px)", &LevelResult::offset_px);
  if (truth) {
    line("TRUE pose angle error (deg)", &LevelResult::true_angle_deg);
    line("TRUE pose distance error (cm)", &LevelResult::true_distance_cm);
    line("EPnP pose vs truth (cm)", &LevelResult::pnp_true_distance_cm);
    std::printf("%-34s", "TRUE co-location RMSE (cm)");
    for (const auto& r : rows)
      std::printf(" | %-31.3f", r.true_rmse_cm);
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
    std::printf(" | %5zu / %-5zu %10.1f s      ", r.matched, r.keyframes, r.ms / 1e3);
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
           {"keyframes", r.keyframes},
           {"matched", r.matched},
           {"pose_angle_deg", stats_json(r.angle_deg)},
           {"pose_distance_cm", stats_json(r.distance_cm)},
           {"distance_2d_px", stats_json(r.offset_px)},
           {"seconds", r.ms / 1e3}};
    if (!truth.empty()) {
      e["true_pose_angle_deg"] = stats_json(r.true_angle_deg);
      e["true_pose_distance_cm"] = stats_json(r.true_distance_cm);
      e["epnp_vs_truth_cm"] = stats_json(r.pnp_true_distance_cm);
      e["true_rmse_cm"] = r.true_rmse_cm;
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
