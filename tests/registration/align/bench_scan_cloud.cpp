// Loading a laser scan for the point-cloud refinement (scan_cloud.hpp): the voxel grid built
// while the file is read (load_scan_cloud) against the batch form (every point in memory, then
// voxel_downsample), which is how scans were loaded before. Run one benchmark per process under
// `/usr/bin/time -v` to compare peak memory:
//   COLOC_SCAN_BENCH_FILE=scan.e57 bench_scan_cloud --benchmark_filter=Streamed
//   COLOC_SCAN_BENCH_FILE=scan.e57 bench_scan_cloud --benchmark_filter=Batch
// Without the variable a synthetic 5 M-point scan (e57io/synthetic.hpp) is written to the temp
// directory. COLOC_SCAN_BENCH_VOXEL sets the voxel size (metres, default 0.01).

#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>

#include "e57io/synthetic.hpp"
#include "registration/align/scan_cloud.hpp"

namespace {

namespace align = coloc::registration::align;

const std::filesystem::path& file() {
  static const std::filesystem::path path = [] {
    if (const char* env = std::getenv("COLOC_SCAN_BENCH_FILE")) return std::filesystem::path(env);
    const auto p = std::filesystem::temp_directory_path() / "coloc_bench_scan_cloud.e57";
    coloc::e57::write_synthetic_scan(p, 5'000'000, 1'000'000);
    return p;
  }();
  return path;
}

align::ScanCloudOptions options() {
  align::ScanCloudOptions o;
  if (const char* env = std::getenv("COLOC_SCAN_BENCH_VOXEL")) o.voxel_size = std::atof(env);
  return o;
}

void report(benchmark::State& state, const align::ScanCloudStats& s) {
  state.counters["points"] = static_cast<double>(s.points_read);
  state.counters["kept"] = static_cast<double>(s.points_kept);
  state.counters["Mpoints/s"] = benchmark::Counter(static_cast<double>(s.points_read) / 1e6,
                                                   benchmark::Counter::kIsIterationInvariantRate);
}

void Streamed(benchmark::State& state) {
  align::ScanCloudStats stats;
  for (auto _ : state)
    benchmark::DoNotOptimize(align::load_scan_cloud(file(), options(), &stats));
  report(state, stats);
}

// What load_scan_cloud did before the streamed grid: every point read into memory first.
void Batch(benchmark::State& state) {
  const align::ScanCloudOptions o = options();
  align::ScanCloudStats stats;
  for (auto _ : state) {
    coloc::registration::render::PointCloud all;
    align::read_scan_pieces(
        file(), o,
        [&](const align::ScanPiece& piece) {
          all.points.insert(all.points.end(), piece.points.begin(), piece.points.end());
          all.colours.insert(all.colours.end(), piece.colours.begin(), piece.colours.end());
          all.splat_sizes.insert(all.splat_sizes.end(), piece.spacings.begin(),
                                 piece.spacings.end());
        },
        &stats,
        [&](std::uint64_t, std::uint64_t total) {
          if (all.points.capacity() >= total) return;  // reserved as the old loader did
          all.points.reserve(total);
          all.colours.reserve(total);
          all.splat_sizes.reserve(total);
        });
    coloc::registration::render::PointCloud out = align::voxel_downsample(all, o);
    align::remove_stray_points(out, o.stray);
    stats.points_kept = out.points.size();
    benchmark::DoNotOptimize(out);
  }
  report(state, stats);
}

BENCHMARK(Streamed)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(Batch)->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace
