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

// CPU time consumed by the calling thread so far, in seconds. On a shared machine wall time also
// counts the time other processes held the core; a benchmark that runs on one thread reports
// this alongside (or instead of) wall time.
double thread_cpu_seconds();

// Stopwatch of the calling thread's CPU time. Start and read it on the same thread.
class ThreadCpuStopwatch {
 public:
  ThreadCpuStopwatch() : start_(thread_cpu_seconds()) {}
  void restart() { start_ = thread_cpu_seconds(); }
  double elapsed_seconds() const { return thread_cpu_seconds() - start_; }
  double elapsed_ms() const { return 1e3 * elapsed_seconds(); }

 private:
  double start_;
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
