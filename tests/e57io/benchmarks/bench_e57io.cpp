// E57 read throughput (DESIGN.md section 5: >= 30 M points/s for ScaledInteger XYZ + colour,
// memory bounded by the chunk). Generates a synthetic scan with our writer once per run
// (COLOC_E57_BENCH_POINTS points, default 5 M), then streams it back in 64 k-point chunks.

#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "e57io/reader.hpp"
#include "e57io/synthetic.hpp"
#include "e57io/writer.hpp"

namespace {

using coloc::e57::field_bit;
using F = coloc::e57::PointField;

std::size_t bench_points() {
  const char* env = std::getenv("COLOC_E57_BENCH_POINTS");
  return env != nullptr ? static_cast<std::size_t>(std::strtoull(env, nullptr, 10)) : 5'000'000;
}

// A scan on a 1 mm grid with colour and intensity, written in 1 M-point pieces.
std::filesystem::path synthetic_file(std::size_t n, const std::string& name) {
  const auto path = std::filesystem::temp_directory_path() / name;
  coloc::e57::write_synthetic_scan(path, n, 1'000'000);
  return path;
}

const std::filesystem::path& file() {
  static const std::filesystem::path path = synthetic_file(bench_points(), "coloc_bench_e57io.e57");
  return path;
}

void read_all(benchmark::State& state, std::uint32_t mask, coloc::e57::ChecksumPolicy crc) {
  const coloc::e57::Reader reader(file(), {.checksums = crc});
  std::uint64_t points = 0;
  for (auto _ : state) {
    coloc::e57::PointStream stream = reader.open_points(0, mask);
    coloc::e57::PointBuffer chunk;
    double sum = 0;
    while (const std::size_t n = stream.read(chunk, 1 << 16)) {
      sum += chunk.cartesian_x[n - 1];
      points += n;
    }
    benchmark::DoNotOptimize(sum);
  }
  state.counters["points/s"] =
      benchmark::Counter(static_cast<double>(points), benchmark::Counter::kIsRate);
}

constexpr std::uint32_t kXyzRgb = field_bit(F::kCartesianX) | field_bit(F::kCartesianY) |
                                  field_bit(F::kCartesianZ) | field_bit(F::kColorRed) |
                                  field_bit(F::kColorGreen) | field_bit(F::kColorBlue);

void BM_ReadXyzRgb(benchmark::State& s) {
  read_all(s, kXyzRgb, coloc::e57::ChecksumPolicy::all());
}
void BM_ReadXyzRgbNoCrc(benchmark::State& s) {
  read_all(s, kXyzRgb, coloc::e57::ChecksumPolicy::none());
}
void BM_ReadAllFields(benchmark::State& s) {
  read_all(s, 0, coloc::e57::ChecksumPolicy::all());
}

void BM_Write(benchmark::State& state) {
  const std::size_t n = 1'000'000;
  for (auto _ : state)
    benchmark::DoNotOptimize(synthetic_file(n, "coloc_bench_e57io_write.e57"));
  state.counters["points/s"] =
      benchmark::Counter(static_cast<double>(n * state.iterations()), benchmark::Counter::kIsRate);
}

BENCHMARK(BM_ReadXyzRgb)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReadXyzRgbNoCrc)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReadAllFields)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Write)->Unit(benchmark::kMillisecond);

}  // namespace
