#include "slam/pipeline/extract_ahead.hpp"

#include <utility>

namespace coloc::slam::pipeline {

ExtractAhead::ExtractAhead(dataset::FrameSource& source, tracking::FeatureExtraction extraction,
                           bool rgb_order, std::size_t capacity)
    : source_(source),
      extraction_(std::move(extraction)),
      rgb_order_(rgb_order),
      queue_(capacity),
      worker_([this] { run(); }) {}

ExtractAhead::~ExtractAhead() {
  queue_.close();  // a worker blocked on a full queue gives up
  worker_.join();
}

std::optional<ExtractedFrame> ExtractAhead::next() {
  auto item = queue_.pop();
  if (!item) return std::nullopt;
  if (item->error) std::rethrow_exception(item->error);
  return std::move(item->extracted);
}

void ExtractAhead::run() {
  try {
    while (auto frame = source_.next()) {
      Item item;
      item.extracted.frame = std::move(*frame);
      cv::Mat& color = item.extracted.frame.color;
      color = dataset::to_camera_order(color, rgb_order_);
      try {
        item.extracted.features = extraction_(color);
      } catch (const std::exception&) {
        // Left to tracking, which checks the image and says what is wrong with it.
      }
      if (!queue_.push(std::move(item))) return;  // the consumer left
    }
  } catch (...) {
    queue_.push(Item{{}, std::current_exception()});
  }
  queue_.close();
}

}  // namespace coloc::slam::pipeline
