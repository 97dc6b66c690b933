#include "slam/localize/frame_pacer.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "slam/core/error.hpp"

namespace coloc::slam::localize {

FramePacer::FramePacer(std::vector<double> timestamps) : timestamps_(std::move(timestamps)) {
  for (std::size_t i = 0; i < timestamps_.size(); ++i) {
    if (!std::isfinite(timestamps_[i]) || (i > 0 && timestamps_[i] < timestamps_[i - 1]))
      throw Error("FramePacer: timestamps must be finite and non-decreasing (frame " +
                      std::to_string(i) + ")",
                  {.field = "timestamps"});
  }
}

std::optional<PacedFrame> FramePacer::next(double elapsed_s) {
  if (next_ >= timestamps_.size()) return std::nullopt;
  const double now = timestamps_.front() + elapsed_s;
  // The newest frame that has arrived by `now` (at or after next_).
  const auto arrived_end =
      std::upper_bound(timestamps_.begin() + static_cast<long>(next_), timestamps_.end(), now);
  PacedFrame f;
  if (arrived_end == timestamps_.begin() + static_cast<long>(next_)) {
    f.index = next_;
    f.wait_s = timestamps_[next_] - now;
  } else {
    f.index = static_cast<std::size_t>(arrived_end - timestamps_.begin()) - 1;
    f.dropped = f.index - next_;
  }
  dropped_ += f.dropped;
  ++processed_;
  next_ = f.index + 1;
  return f;
}

}  // namespace coloc::slam::localize
