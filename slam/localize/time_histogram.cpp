#include "slam/localize/time_histogram.hpp"

#include <algorithm>
#include <cmath>

namespace coloc::slam::localize {

TimeHistogram::TimeHistogram() : bins_(static_cast<std::size_t>(kRangeMs / kBinMs) + 1, 0) {}

void TimeHistogram::add(double ms) {
  if (!std::isfinite(ms) || ms < 0.0) ms = 0.0;
  const auto bin = std::min(static_cast<std::size_t>(ms / kBinMs), bins_.size() - 1);
  ++bins_[bin];
  ++count_;
  sum_ += ms;
  max_ = std::max(max_, ms);
}

double TimeHistogram::quantile(double q) const {
  if (count_ == 0) return 0.0;
  q = std::clamp(q, 0.0, 1.0);
  // The rank of numpy's "lower" order statistic: the smallest bin holding it.
  const auto rank = static_cast<std::uint64_t>(std::floor(q * static_cast<double>(count_ - 1)));
  std::uint64_t seen = 0;
  for (std::size_t b = 0; b < bins_.size(); ++b) {
    seen += bins_[b];
    if (seen > rank) {
      if (b + 1 == bins_.size()) return max_;
      return std::min((static_cast<double>(b) + 0.5) * kBinMs, max_);
    }
  }
  return max_;
}

}  // namespace coloc::slam::localize
