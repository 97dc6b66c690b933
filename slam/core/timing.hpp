#pragma once
// Timing helpers for `coloc bench` and per-stage statistics. Speed is measured by benchmarks,
// never asserted in tests.

#include <chrono>
#include <cstddef>
#include <vector>

namespace coloc {

class Stopwatch {
 public:
  Stopwatch() : start_(std::chrono::steady_clock::now()) {}
  void restart() { start_ = std::chrono::steady_clock::now(); }
  double elapsed_seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
  double elapsed_ms() const { return 1e3 * elapsed_seconds(); }

 private:
  std::chrono::steady_clock::time_point start_;
};

// Summary of a set of samples (any unit; the caller names it).
struct SampleStats {
  std::size_t count = 0;
  double mean = 0.0;
  double median = 0.0;
  double p99 = 0.0;
  double min = 0.0;
  double max = 0.0;
  double stddev = 0.0;  // population standard deviation
};

// Quantiles by linear interpolation between order statistics (numpy's default).
double quantile(std::vector<double> samples, double q);
SampleStats summarize(const std::vector<double>& samples);

}  // namespace coloc
