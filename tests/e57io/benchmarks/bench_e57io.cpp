// E57 read throughput (DESIGN.md section 5: >= 30 M points/s for ScaledInteger XYZ + colour,
// memory bounded by the chunk). Generates a synthetic scan with our writer once per run
// (COLOC_E57_BENCH_POINTS points, default 5 M), then streams it back in 64 k-point chunks.

#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "e57io/reader.hpp"
#include "e57io/writer.hpp"

namespace {

using coloc::e57::field_bit;
using coloc::e57::FieldSpec;
using F = coloc::e57::PointField;

std::size_t bench_points() {
  const char* env = std::getenv("COLOC_E57_BENCH_POINTS");
  return env != nullptr ? static_cast<std::size_t>(std::strtoull(env, nullptr, 10)) : 5'000'000;
}

// A scan on a 1 mm grid with colour and intensity, written in 1 M-point pieces.
std::filesystem::path synthetic_file(std::size_t n, const std::string& name) {
  const auto path = std::filesystem::temp_directory_path() / name;
  coloc::e57::Writer w(path);
  w.begin_scan(
      {.name = "synthetic"},
      {FieldSpec::scaled(F::kCartesianX, 1e-4, -100, 100),
       FieldSpec::scaled(F::kCartesianY, 1e-4, -100, 100),
       FieldSpec::scaled(F::kCartesianZ, 1e-4, -100, 100),
       FieldSpec::integer(F::kIntensity, 0, 2047), FieldSpec::integer(F::kColorRed, 0, 255),
       FieldSpec::integer(F::kColorGreen, 0, 255), FieldSpec::integer(F::kColorBlue, 0, 255)});
  coloc::e57::PointBuffer p;
  for (std::size_t at = 0; at < n;) {
    const std::size_t k = std::min<std::size_t>(n - at, 1'000'000);
    p.reset(field_bit(F::kCartesianX) | field_bit(F::kCartesianY) | field_bit(F::kCartesianZ) |
                field_bit(F::kIntensity) | field_bit(F::kColorRed) | field_bit(F::kColorGreen) |
                field_bit(F::kColorBlue),
            k);
    for (std::size_t i = 0; i < k; ++i) {
      const std::size_t j = at + i;
      p.cartesian_x[i] = -50.0 + 1e-3 * static_cast<double>(j % 100000);
      p.cartesian_y[i] = -50.0 + 1e-3 * static_cast<double>((j / 100000) % 100000);
      p.cartesian_z[i] = 1e-4 * static_cast<double>(j % 30011);
      p.intensity[i] = static_cast<float>(j % 2048);
      p.color_red[i] = static_cast<float>(j % 256);
      p.color_green[i] = static_cast<float>((j / 3) % 256);
      p.color_blue[i] = static_cast<float>((j / 7) % 256);
    }
    w.add_points(p);
    at += k;
  }
  w.end_scan();
  w.close();
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
