#pragma once
// Per-frame times over a session of any length in fixed memory: a histogram of 0.01 ms bins up
// to 200 ms (larger values land in the last bin and are also kept as the maximum). Quantiles
// are exact to the bin width, which is below what a timer on a shared machine resolves.
// Not thread-safe.
#include <cstdint>
#include <vector>

namespace coloc::slam::localize {

class TimeHistogram {
 public:
  static constexpr double kBinMs = 0.01;
  static constexpr double kRangeMs = 200.0;

  TimeHistogram();
  void add(double ms);  // negative or non-finite values count as 0
  std::uint64_t count() const { return count_; }
  double mean() const { return count_ ? sum_ / static_cast<double>(count_) : 0.0; }
  double max() const { return max_; }
  // The q-quantile (0 <= q <= 1), the centre of its bin (the maximum above the range); 0 when
  // empty.
  double quantile(double q) const;

 private:
  std::vector<std::uint32_t> bins_;
  std::uint64_t count_ = 0;
  double sum_ = 0.0, max_ = 0.0;
};

}  // namespace coloc::slam::localize
