// coloc bench mapdb: save and load a synthetic N-keyframe map (default 5000 keyframes of 1000
// keypoints, the DESIGN target): save time and file size per keyframe, peak memory above the
// map during a save (plain and live), how long a live save holds the map lock and how long a
// simulated 30 Hz tracker waits for it, and load time.

#include <malloc.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/slam_inputs.hpp"
#include "Examples/coloc/verbs.hpp"
#include "slam/core/progress.hpp"
#include "slam/core/row_progress.hpp"
#include "slam/mapdb/mapdb.hpp"
#include "slam/mapdb/synthetic_map.hpp"

namespace coloc::cli {
namespace {

namespace fs = std::filesystem;
namespace mapdb = slam::mapdb;
using Clock = std::chrono::steady_clock;

struct MapdbBenchArgs {
  int keyframes = 5000;
  int keypoints = 1000;
  fs::path dir;
  fs::path vocabulary;
  bool json = false;
  bool keep = false;
};

// Resident memory now and its peak since reset_peak() (Linux /proc), MiB.
double status_mib(const char* key) {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line)) {
    if (line.rfind(key, 0) == 0) return std::stod(line.substr(std::string(key).size())) / 1024.0;
  }
  return 0.0;
}
double rss_mib() {
  return status_mib("VmRSS:");
}
double peak_mib() {
  return status_mib("VmHWM:");
}
void reset_peak() {
  malloc_trim(0);  // freed heap returned first, so "above the map" is the save's own memory
  std::ofstream("/proc/self/clear_refs") << "5";
}

double since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// A tracker at 30 Hz that takes the map lock once per frame: how long it had to wait.
class SimulatedTracker {
 public:
  explicit SimulatedTracker(std::mutex& mutex) : mutex_(mutex), thread_([this] { run(); }) {}
  ~SimulatedTracker() {
    stop_ = true;
    thread_.join();
  }
  double max_wait_ms() const { return max_wait_ms_; }

 private:
  void run() {
    while (!stop_) {
      const auto t0 = Clock::now();
      { std::lock_guard lock(mutex_); }
      max_wait_ms_ = std::max(max_wait_ms_.load(), 1e3 * since(t0));
      std::this_thread::sleep_for(std::chrono::milliseconds(33));
    }
  }
  std::mutex& mutex_;
  std::atomic<bool> stop_{false};
  std::atomic<double> max_wait_ms_{0.0};
  std::thread thread_;
};

struct Figures {
  std::size_t keyframes = 0, points = 0, observations = 0;
  double map_mib = 0;
  mapdb::SaveReport save, live;
  double save_peak_mib = 0, live_peak_mib = 0, tracker_wait_ms = 0;
  double load_s = 0, load_peak_mib = 0;
};

void print(const MapdbBenchArgs& a, const Figures& f) {
  const double n = static_cast<double>(f.keyframes);
  if (a.json) {
    print_json({{"keyframes", f.keyframes},
                {"keypoints_per_keyframe", a.keypoints},
                {"map_points", f.points},
                {"observations", f.observations},
                {"map_mib", f.map_mib},
                {"save_s", f.save.seconds},
                {"save_ms_per_keyframe", 1e3 * f.save.seconds / n},
                {"bytes", f.save.bytes},
                {"bytes_per_keyframe", static_cast<double>(f.save.bytes) / n},
                {"save_peak_above_map_mib", f.save_peak_mib},
                {"live_save_s", f.live.seconds},
                {"live_save_peak_above_map_mib", f.live_peak_mib},
                {"live_max_lock_ms", f.live.max_lock_ms},
                {"live_locks", f.live.locks},
                {"tracker_max_wait_ms", f.tracker_wait_ms},
                {"load_s", f.load_s},
                {"load_ms_per_keyframe", 1e3 * f.load_s / n},
                {"load_peak_mib", f.load_peak_mib}});
    return;
  }
  std::printf(
      "synthetic map: %zu keyframes x %d keypoints, %zu map points, %zu observations; the map "
      "takes %.0f MiB\n",
      f.keyframes, a.keypoints, f.points, f.observations, f.map_mib);
  std::printf(
      "save:      %.2f s = %.2f ms/keyframe; file %.1f MB = %.0f bytes/keyframe; peak "
      "memory above the map %.1f MiB\n",
      f.save.seconds, 1e3 * f.save.seconds / n, static_cast<double>(f.save.bytes) / 1e6,
      static_cast<double>(f.save.bytes) / n, f.save_peak_mib);
  std::printf(
      "live save: %.2f s; peak memory above the map %.1f MiB; map lock held %zu times, "
      "longest %.2f ms (snapshot), %.0f ms in total; a 30 Hz tracker waited at most "
      "%.2f ms\n",
      f.live.seconds, f.live_peak_mib, f.live.locks, f.live.max_lock_ms, f.live.total_lock_ms,
      f.tracker_wait_ms);
  std::printf(
      "load:      %.2f s = %.2f ms/keyframe (checks, frames, BoW and database rebuilt); "
      "peak memory %.0f MiB (the loaded map included)\n",
      f.load_s, 1e3 * f.load_s / n, f.load_peak_mib);
}

void run_bench(const MapdbBenchArgs& a) {
  const slam::bow::Vocabulary vocabulary = load_vocabulary(a.vocabulary);
  mapdb::MapMetadata metadata;
  metadata.vocabulary_checksum = mapdb::vocabulary_checksum(vocabulary);
  metadata.vocabulary_words = vocabulary.word_count();
  metadata.settings = "coloc bench mapdb: synthetic map";
  metadata.camera = PinholeCamera{640, 480, 525.0, 525.0, 319.5, 239.5, {}};
  const fs::path dir = a.dir.empty() ? fs::temp_directory_path() / "coloc_bench_mapdb" : a.dir;
  fs::create_directories(dir);
  const fs::path path = dir / "bench.db";

  Figures f;
  reset_peak();
  const double before_map = rss_mib();
  auto map = std::make_unique<slam::map::Map>();
  {
    Progress p("building synthetic map", static_cast<std::uint64_t>(a.keyframes), a.json);
    slam::mapdb::SyntheticMapOptions o;
    o.keyframes = a.keyframes;
    o.keypoints = a.keypoints;
    *map =
        mapdb::make_synthetic_map(o, mapdb::synthetic_geometry(), &vocabulary,
                                  [&](int done, int) { p.set(static_cast<std::uint64_t>(done)); });
  }
  reset_peak();
  f.map_mib = rss_mib() - before_map;
  {
    RowProgress p("save", a.json);
    const double base = rss_mib();
    f.save = mapdb::save_map(*map, metadata, path, {.progress = p.callback()});
    p.finish();
    f.save_peak_mib = peak_mib() - base;
  }
  f.keyframes = f.save.keyframes;
  f.points = f.save.points;
  f.observations = f.save.observations;
  {
    std::mutex mutex;
    SimulatedTracker tracker(mutex);
    RowProgress p("live save", a.json);
    reset_peak();
    const double base = rss_mib();
    f.live = mapdb::save_live_map(*map, mutex, metadata, path, {.progress = p.callback()});
    p.finish();
    f.live_peak_mib = peak_mib() - base;
    f.tracker_wait_ms = tracker.max_wait_ms();
  }
  map.reset();  // the load builds its own
  {
    RowProgress p("load", a.json);
    reset_peak();
    const auto t0 = Clock::now();
    const mapdb::LoadedMap loaded = mapdb::load_map(path, vocabulary, {.progress = p.callback()});
    p.finish();
    f.load_s = since(t0);
    f.load_peak_mib = peak_mib();
    if (loaded.map.keyframe_count() != f.keyframes)
      throw CliFailure("the loaded map has another keyframe count");
  }
  print(a, f);
  if (!a.keep) fs::remove(path);
}

}  // namespace

void add_mapdb_bench(CLI::App& bench) {
  auto a = std::make_shared<MapdbBenchArgs>();
  CLI::App& cmd = *bench.add_subcommand(
      "mapdb", "Map database: save/load time, bytes per keyframe, memory above the map");
  cmd.add_option("--keyframes", a->keyframes, "Keyframes of the synthetic map")
      ->check(CLI::Range(1, 1000000));
  cmd.add_option("--keypoints", a->keypoints, "Keypoints per keyframe")
      ->check(CLI::Range(1, 100000));
  cmd.add_option("--dir", a->dir, "Where to write the map (default: the temp directory)");
  cmd.add_option("--vocabulary", a->vocabulary, "BoW vocabulary (default: the shipped one)");
  cmd.add_flag("--keep", a->keep, "Keep the map file");
  cmd.add_flag("--json", a->json, "Machine-readable output on stdout");
  cmd.callback([a] { run_bench(*a); });
}

}  // namespace coloc::cli
