#include "fusion/pose_buffer.hpp"

#include <algorithm>

namespace coloc::fusion {

PoseBuffer::PoseBuffer(double window_seconds, std::size_t max_size)
    : window_seconds_(window_seconds), max_size_(std::max<std::size_t>(max_size, 2)) {}

bool PoseBuffer::push(double time, const SE3& pose) {
  if (!poses_.empty() && !(time > poses_.back().time)) return false;
  poses_.push_back({time, pose});
  while (poses_.size() > max_size_ ||
         (poses_.size() > 2 && poses_.front().time < time - window_seconds_)) {
    poses_.pop_front();
  }
  return true;
}

std::optional<SE3> PoseBuffer::at(double time, double max_extrapolation) const {
  if (poses_.empty() || time < poses_.front().time) return std::nullopt;
  if (time >= poses_.back().time) {
    if (time - poses_.back().time <= max_extrapolation) return poses_.back().pose;
    return std::nullopt;
  }
  // First sample strictly after `time`; its predecessor is at or before it.
  const auto after =
      std::upper_bound(poses_.begin(), poses_.end(), time,
                       [](double t, const StampedSE3& sample) { return t < sample.time; });
  const auto before = std::prev(after);
  const double fraction = (time - before->time) / (after->time - before->time);
  return interpolate(before->pose, after->pose, fraction);
}

std::optional<StampedSE3> PoseBuffer::newest() const {
  if (poses_.empty()) return std::nullopt;
  return poses_.back();
}

}  // namespace coloc::fusion
