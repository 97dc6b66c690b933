#include "slam/dataset/frame_source.hpp"

#include <spdlog/spdlog.h>

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

}  // namespace

std::unique_ptr<FrameSource> frames_of(const Sequence& sequence) {
  return std::make_unique<SequenceFrames>(sequence);
}

}  // namespace coloc::dataset
