#include "slam/pipeline/extract_ahead.hpp"

#include <exception>
#include <utility>

namespace coloc::slam::pipeline {

ExtractAhead::ExtractAhead(dataset::FrameSource& source, tracking::FeatureExtraction extraction,
                           bool rgb_order, std::size_t capacity)
    : source_(source),
      extraction_(std::move(extraction)),
      rgb_order_(rgb_order),
      worker_([this] { return extract_next(); }, capacity) {}

std::optional<ExtractedFrame> ExtractAhead::extract_next() {
  auto frame = source_.next();
  if (!frame) return std::nullopt;
  ExtractedFrame out{std::move(*frame), std::nullopt};
  out.frame.color = dataset::to_camera_order(out.frame.color, rgb_order_);
  try {
    out.features = extraction_(out.frame.color);
  } catch (const std::exception&) {
    // Left to tracking, which checks the image and says what is wrong with it.
  }
  return out;
}

}  // namespace coloc::slam::pipeline
