#include "slam/dataset/frame_source.hpp"

#include <spdlog/spdlog.h>

#include <chrono>
#include <thread>

#include "slam/core/error.hpp"

namespace coloc::dataset {
namespace {

class SequenceFrames final : public FrameSource {
 public:
  explicit SequenceFrames(const Sequence& sequence) : sequence_(sequence) {}

  std::optional<Frame> next() override {
    while (next_ < sequence_.size()) {
      const std::size_t i = next_++;
      try {
        return sequence_.frame(i);
      } catch (const Error& e) {
        spdlog::warn("frame {} skipped: {}", i, e.what());
        ++skipped_;
      }
    }
    return std::nullopt;
  }
  std::size_t remaining() const override { return sequence_.size() - next_; }
  std::size_t skipped() const override { return skipped_; }

 private:
  const Sequence& sequence_;
  std::size_t next_ = 0, skipped_ = 0;
};

class PacedFrames final : public FrameSource {
 public:
  explicit PacedFrames(std::unique_ptr<FrameSource> source) : source_(std::move(source)) {}

  std::optional<Frame> next() override {
    auto frame = source_->next();
    if (!frame) return frame;
    using Clock = std::chrono::steady_clock;
    if (!first_) {
      first_ = frame->timestamp;
      start_ = Clock::now();
      return frame;
    }
    const auto due = start_ + std::chrono::duration_cast<Clock::duration>(
                                  std::chrono::duration<double>(frame->timestamp - *first_));
    std::this_thread::sleep_until(due);
    return frame;
  }
  std::size_t remaining() const override { return source_->remaining(); }
  std::size_t skipped() const override { return source_->skipped(); }

 private:
  std::unique_ptr<FrameSource> source_;
  std::optional<double> first_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace

std::unique_ptr<FrameSource> paced(std::unique_ptr<FrameSource> source) {
  return std::make_unique<PacedFrames>(std::move(source));
}

std::unique_ptr<FrameSource> frames_of(const Sequence& sequence) {
  return std::make_unique<SequenceFrames>(sequence);
}

}  // namespace coloc::dataset
