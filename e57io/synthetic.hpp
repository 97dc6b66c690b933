#pragma once
// A synthetic scan for throughput measurements: points on a 1 mm grid with intensity and colour,
// stored as the large files of real scanners are (ScaledInteger XYZ at 0.1 mm, Integer
// intensity 0..2047 and colour 0..255). Used by `coloc bench e57` and the Google Benchmark.

#include <cstddef>
#include <filesystem>
#include <functional>

namespace coloc::e57 {

// Writes `points` points (one data3D) to `path`, in pieces of `chunk` points. `on_progress`,
// when given, is called after each piece with the number of points written so far.
// Throws coloc::e57::Error when the file cannot be written.
void write_synthetic_scan(const std::filesystem::path& path, std::size_t points,
                          std::size_t chunk = 1 << 18,
                          const std::function<void(std::size_t)>& on_progress = {});

}  // namespace coloc::e57
