#include "slam/dataset/frame_source.hpp"

#include <spdlog/spdlog.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <thread>

#include "slam/core/error.hpp"
#include "slam/core/prefetch.hpp"

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
      previous_ = frame->timestamp;
      start_ = Clock::now();
      return frame;
    }
    const auto at = [&](double t) {
      return start_ + std::chrono::duration_cast<Clock::duration>(
                          std::chrono::duration<double>(t - *first_));
    };
    const auto due = at(frame->timestamp);
    // The next frame's time is unknown here; the gap to the previous one stands for it.
    if (Clock::now() >= at(2.0 * frame->timestamp - previous_)) ++late_;
    previous_ = frame->timestamp;
    std::this_thread::sleep_until(due);
    return frame;
  }
  std::size_t remaining() const override { return source_->remaining(); }
  std::size_t skipped() const override { return source_->skipped(); }
  std::size_t late() const override { return late_; }

 private:
  std::unique_ptr<FrameSource> source_;
  std::optional<double> first_;
  double previous_ = 0.0;  // timestamp of the frame handed out before
  std::size_t late_ = 0;
  std::chrono::steady_clock::time_point start_;
};

class ReadAheadFrames final : public FrameSource {
 public:
  ReadAheadFrames(std::unique_ptr<FrameSource> source, std::size_t capacity)
      : source_(std::move(source)),
        source_remaining_(source_->remaining()),
        counted_(source_remaining_ > 0),
        reader_([this] { return read(); }, capacity) {}

  std::optional<Frame> next() override {
    auto frame = reader_.next();
    if (frame) {
      const std::lock_guard lock(count_mutex_);
      ++handed_;
    }
    return frame;
  }
  // Frames not handed out yet: the source's own count plus those read and not handed out. A
  // source without a count (a camera, an endless generator) stays without one (0), however many
  // frames the reader thread happens to hold: the answer must not depend on its progress.
  std::size_t remaining() const override {
    if (!counted_) return 0;
    const std::lock_guard lock(count_mutex_);
    return source_remaining_ + read_ - handed_;
  }
  std::size_t skipped() const override { return skipped_.load(); }

 private:
  std::optional<Frame> read() {  // on the reader thread
    auto frame = source_->next();
    if (frame) {
      // Both at once, so remaining() never sees a frame in flight twice or not at all.
      const std::lock_guard lock(count_mutex_);
      ++read_;
      source_remaining_ = source_->remaining();
    }
    skipped_.store(source_->skipped());
    return frame;
  }

  std::unique_ptr<FrameSource> source_;
  mutable std::mutex count_mutex_;
  std::size_t source_remaining_;       // the source's remaining() after its last read
  const bool counted_;                 // the source gave a count when it was wrapped
  std::size_t read_ = 0, handed_ = 0;  // frames read from the source, handed out by next()
  std::atomic<std::size_t> skipped_{0};
  Prefetch<Frame> reader_;  // last: its thread reads the members above
};

}  // namespace

std::unique_ptr<FrameSource> read_ahead(std::unique_ptr<FrameSource> source, std::size_t capacity) {
  return std::make_unique<ReadAheadFrames>(std::move(source), capacity);
}

std::unique_ptr<FrameSource> paced(std::unique_ptr<FrameSource> source) {
  return std::make_unique<PacedFrames>(std::move(source));
}

std::unique_ptr<FrameSource> frames_of(const Sequence& sequence) {
  return std::make_unique<SequenceFrames>(sequence);
}

}  // namespace coloc::dataset
