#include "slam/capture/live_frames.hpp"

namespace coloc::capture {

std::optional<dataset::Frame> LiveFrames::next() {
  std::optional<RgbdFrame> f = camera_.next();
  if (!f) return std::nullopt;
  dataset::Frame out;
  out.index = index_++;
  out.timestamp = f->timestamp;
  out.color = std::move(f->color);
  f->depth_raw.convertTo(out.depth, CV_32F, 1.0 / camera_.options().depth_units_per_metre);
  return out;
}

}  // namespace coloc::capture
