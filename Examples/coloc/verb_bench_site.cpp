// `coloc bench site DIR`: the whole chain at the size of a real site (Michiels et al. 2024,
// Table 1: 160-312 m2, 800 keyframes, scans of hundreds of millions of points) on the twin's
// `site` preset, one stage per child process so each stage's wall time, CPU time and peak
// resident memory are the kernel's accounting of that stage alone. Generated data in DIR is
// reused (generation is a stage of its own, timed only when it runs). Prints one table;
// --json prints it as a document.

#include <spdlog/spdlog.h>

#include <opencv2/core/persistence.hpp>
#include <optional>

#include "Examples/coloc/child_verb.hpp"
#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/verbs.hpp"
#include "slam/core/error.hpp"

namespace coloc::cli {
namespace {

namespace fs = std::filesystem;

struct SiteBenchArgs {
  fs::path dir;
  std::string preset = "site";  // another preset tries the bench in minutes
  int seed = 1;
  double survey_seconds = 0.0;  // 0: the whole survey walk
  double walk_seconds = 180.0;  // test walk 1: 5,400 frames at 30 Hz
  int face_size = 0;            // 0: the preset's scan
  int point_step = 0;
  double marker_distance = 5.0;  // scan-markers --max-distance (metres)
  int cold_starts = 50;
  int cold_start_every = 10;  // frames of the test walk kept for the cold starts
  bool json = false;
};

struct Stage {
  std::string name;
  std::optional<VerbCost> cost;  // absent: reused, not run
  Json figures = Json::object();
};

// The twin's own account of what it generated (twin.yaml, OpenCV YAML).
Json twin_facts(const fs::path& twin_yaml) {
  cv::FileStorage fs_in(twin_yaml.string(), cv::FileStorage::READ);
  if (!fs_in.isOpened()) throw Error("cannot read the twin's summary", {.file = twin_yaml});
  Json facts;
  for (const char* key : {"frames", "stations", "scan_points", "markers", "marker_dictionary"})
    facts[key] = static_cast<double>(fs_in[key]);
  facts["path_length_m"] = static_cast<double>(fs_in["path_length"]);
  return facts;
}

// Generates with `args` unless `twin_dir` holds a finished twin (its twin.yaml is written last).
Stage generate(const std::string& name, const fs::path& twin_dir,
               const std::vector<std::string>& args) {
  Stage stage{name, std::nullopt, Json::object()};
  if (fs::exists(twin_dir / "twin.yaml")) {
    std::printf("  %s exists: reused (delete it to regenerate)\n", twin_dir.c_str());
  } else {
    stage.cost = measure_verb(args, false);
  }
  stage.figures = twin_facts(twin_dir / "twin.yaml");
  return stage;
}

double number(const Json& j, const char* key) {
  return j.contains(key) && j[key].is_number() ? j[key].get<double>() : 0.0;
}

std::string figures_text(const Json& figures) {
  std::string text;
  for (const auto& [key, value] : figures.items()) {
    if (!text.empty()) text += ", ";
    char buf[64];
    if (value.is_number_float())
      std::snprintf(buf, sizeof(buf), "%.4g", value.get<double>());
    else
      std::snprintf(buf, sizeof(buf), "%s", value.dump().c_str());
    text += key + " " + buf;
  }
  return text;
}

// One row of the table: wall s, CPU s, peak MiB, figures.
std::string row_text(const Stage& s) {
  char buf[128];
  if (s.cost)
    std::snprintf(buf, sizeof(buf), "%-28s %9.1f %9.1f %10.0f  ", s.name.c_str(), s.cost->wall_s,
                  s.cost->cpu_s, static_cast<double>(s.cost->peak_rss_bytes) / (1024.0 * 1024.0));
  else
    std::snprintf(buf, sizeof(buf), "%-28s %9s %9s %10s  ", s.name.c_str(), "reused", "", "");
  return buf + figures_text(s.figures);
}

// Keeps a finished stage and logs its row at once, so a run stopped part way (an hour at the
// paper's size) keeps what it measured.
void keep(std::vector<Stage>& stages, Stage stage) {
  spdlog::info("bench site: {}", row_text(stage));
  stages.push_back(std::move(stage));
}

std::vector<Stage> run_site(const SiteBenchArgs& a) {
  fs::create_directories(a.dir);
  const fs::path site = a.dir / "site", walk = a.dir / "site_walk1";
  const std::string seed = std::to_string(a.seed), vocabulary = shipped_vocabulary().string();
  std::vector<Stage> stages;

  std::vector<std::string> gen = {"twin",   "generate", "--preset", a.preset,
                                  "--seed", seed,       "--out",    site.string()};
  if (a.survey_seconds > 0) gen.insert(gen.end(), {"--seconds", std::to_string(a.survey_seconds)});
  if (a.face_size > 0) gen.insert(gen.end(), {"--face-size", std::to_string(a.face_size)});
  if (a.point_step > 0) gen.insert(gen.end(), {"--point-step", std::to_string(a.point_step)});
  keep(stages, generate("twin: survey + scan", site, gen));
  keep(stages, generate("twin: test walk 1", walk,
                        {"twin", "generate", "--preset", a.preset, "--seed", seed, "--walk", "1",
                         "--no-scan", "--seconds", std::to_string(a.walk_seconds), "--out",
                         walk.string()}));
  const std::string e57 = (site / "scan" / "scan.e57").string();
  const std::string dictionary =
      std::to_string(static_cast<int>(stages.front().figures.value("marker_dictionary", 0.0)));

  const fs::path markers = a.dir / "markers.yaml";
  Json j;
  // The site's rooms are 6 m across with one station in the middle, so most markers are 3-4.5 m
  // from the nearest station, beyond scan-markers' default 3 m.
  Stage found{
      "scan-markers",
      measure_verb({"scan-markers", e57, "--dictionary", dictionary, "--size", "0.1675",
                    "--max-distance", std::to_string(a.marker_distance), "--out", markers.string(),
                    "--truth", (site / "groundtruth" / "markers.txt").string()},
                   true, &j),
      Json::object()};
  found.figures = {{"markers", j["markers"].size()},
                   {"markers_in_scan", stages.front().figures.value("markers", 0.0)},
                   {"corner_error_mean_mm", 1e3 * number(j.value("truth", Json()), "mean_m")}};
  keep(stages, std::move(found));

  const fs::path map_db = a.dir / "site_map.db";
  Stage map{"map --realtime",
            measure_verb(
                {"map", "--sequence", (site / "sequence").string(), "--vocabulary", vocabulary,
                 "--realtime", "--trajectory", (a.dir / "map_trajectory.txt").string(),
                 "--keyframes", (a.dir / "map_keyframes.txt").string(), "--save", map_db.string()},
                true, &j),
            Json::object()};
  map.figures = {
      {"frames", j["frames"]},
      {"keyframes", j["keyframes"]},
      {"late_frames", j["late_frames"]},
      {"late_percent", 100.0 * number(j, "late_frames") / std::max(1.0, number(j, "frames"))},
      {"local_ba_ms_median", j["local_ba_ms_median"]},
      {"local_ba_ms_p99", j["local_ba_ms_p99"]},
      {"loops", j["loops"]},
      {"global_ba_s", 1e-3 * number(j, "global_ba_ms")},
      {"ate_mm", 1e3 * number(j, "ate_rmse_m")}};
  keep(stages, std::move(map));

  const fs::path markers_db = a.dir / "site_map_markers.db", cloud_db = a.dir / "site_map_cloud.db";
  Stage by_markers{
      "register --level markers",
      measure_verb({"register", "--map", map_db.string(), "--markers", markers.string(), "--out",
                    markers_db.string(), "--level", "markers"},
                   true, &j),
      Json::object()};
  const Json rms = j.value("markers", Json()).value("marker_rms_px", Json());
  by_markers.figures = {{"markers_used", number(j.value("rough", Json()), "inliers")},
                        {"marker_rms_px", rms.is_array() && rms.size() == 2 ? rms[1] : Json()}};
  keep(stages, std::move(by_markers));
  Stage by_cloud{"register --level pointcloud",
                 measure_verb({"register", "--map", map_db.string(), "--markers", markers.string(),
                               "--out", cloud_db.string(), "--level", "pointcloud", "--scan", e57,
                               "--refine-spacing", "1"},
                              true, &j),
                 Json::object()};
  const Json refined = j.value("pointcloud", Json());
  by_cloud.figures = {{"keyframes", number(refined, "keyframes")},
                      {"accepted", number(refined, "accepted")},
                      {"median_correction_mm", 1e3 * number(refined, "median_correction_m")}};
  keep(stages, std::move(by_cloud));

  const std::string walk_sequence = (walk / "sequence").string();
  Stage localize{"localize test walk 1",
                 measure_verb({"localize", "--map", cloud_db.string(), "--sequence", walk_sequence,
                               "--trajectory", (a.dir / "walk1_localized.txt").string()},
                              true, &j),
                 Json::object()};
  localize.figures = {
      {"frames", j["frames"]},
      {"localized_percent", 100.0 * number(j, "localized") / std::max(1.0, number(j, "frames"))},
      {"ms_median", j["ms_per_frame_median"]},
      {"ms_p99", j["ms_per_frame_p99"]},
      {"colocation_rmse_mm", 1e3 * number(j, "ate_unaligned_rmse_m")}};
  keep(stages, std::move(localize));

  Stage cold{
      "cold starts",
      measure_verb({"bench", "localize", "--map", cloud_db.string(), "--sequence", walk_sequence,
                    "--runs", "0", "--cold-starts", std::to_string(a.cold_starts), "--every",
                    std::to_string(a.cold_start_every)},
                   true, &j),
      Json::object()};
  const Json starts = j.value("cold_start", Json());
  cold.figures = {{"map_resident_mb", j["map_resident_mb"]},
                  {"localized", number(starts, "localized")},
                  {"attempts", number(starts, "attempts")},
                  {"ms_median", number(starts, "ms_median")},
                  {"ms_p99", number(starts, "ms_p99")}};
  keep(stages, std::move(cold));
  return stages;
}

void print_table(const std::vector<Stage>& stages) {
  std::printf("\n%-28s %9s %9s %10s  %s\n", "stage", "wall s", "CPU s", "peak MiB", "figures");
  for (const Stage& s : stages)
    std::printf("%s\n", row_text(s).c_str());
}

void run_bench_site(const SiteBenchArgs& a) {
  const std::vector<Stage> stages = run_site(a);
  if (!a.json) {
    print_table(stages);
    return;
  }
  Json rows = Json::array();
  for (const Stage& s : stages) {
    Json row = {{"stage", s.name}, {"figures", s.figures}};
    if (s.cost) {
      row["wall_s"] = s.cost->wall_s;
      row["cpu_s"] = s.cost->cpu_s;
      row["peak_rss_mib"] = static_cast<double>(s.cost->peak_rss_bytes) / (1024.0 * 1024.0);
    }
    rows.push_back(std::move(row));
  }
  print_json({{"dir", a.dir.string()}, {"stages", rows}});
}

}  // namespace

void add_bench_site_verb(CLI::App& bench) {
  auto args = std::make_shared<SiteBenchArgs>();
  CLI::App* b = bench.add_subcommand(
      "site",
      "The whole chain on a generated site (twin preset 'site'): time, CPU, memory, "
      "accuracy per stage");
  b->add_option("DIR", args->dir, "Working folder (generated data in it is reused)")->required();
  b->add_option("--preset", args->preset, "Twin preset (room, floor, building: a quick try)")
      ->capture_default_str();
  b->add_option("--seed", args->seed, "Twin seed")->capture_default_str();
  b->add_option("--survey-seconds", args->survey_seconds,
                "Cut the survey walk to this many seconds (0: the whole walk)")
      ->check(non_negative_seconds());
  b->add_option("--walk-seconds", args->walk_seconds, "Length of test walk 1 (seconds)")
      ->check(CLI::Range(1.0, 3600.0))
      ->capture_default_str();
  b->add_option("--face-size", args->face_size, "Scan cube-face size (0: the preset's)");
  b->add_option("--point-step", args->point_step, "One scan point every N face pixels (0: preset)");
  b->add_option("--marker-distance", args->marker_distance,
                "scan-markers --max-distance: farthest marker from a station (metres)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  b->add_option("--cold-starts", args->cold_starts, "Random first frames to relocalize")
      ->check(CLI::Range(1, 10000))
      ->capture_default_str();
  b->add_option("--cold-start-every", args->cold_start_every,
                "Every Nth frame of the test walk is a cold-start candidate")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  b->add_flag("--json", args->json, "Machine-readable table");
  b->callback([args] { run_bench_site(*args); });
}

}  // namespace coloc::cli
