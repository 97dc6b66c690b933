// dataset::paced and dataset::read_ahead: how a recording's frames reach tracking (coloc map).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <memory>
#include <thread>

#include "slam/core/error.hpp"
#include "slam/dataset/frame_source.hpp"

namespace coloc::dataset {
namespace {

// Frames with the given timestamps and nothing else.
class ListedFrames final : public FrameSource {
 public:
  explicit ListedFrames(std::vector<double> timestamps) : timestamps_(std::move(timestamps)) {}
  std::optional<Frame> next() override {
    if (next_ == timestamps_.size()) return std::nullopt;
    Frame f;
    f.index = next_;
    f.timestamp = timestamps_[next_++];
    return f;
  }
  std::size_t remaining() const override { return timestamps_.size() - next_; }
  std::size_t skipped() const override { return 3; }

 private:
  std::vector<double> timestamps_;
  std::size_t next_ = 0;
};

TEST(PacedFrames, HandsEveryFrameOutNoEarlierThanItsTimestamp) {
  // Timestamps start anywhere (TUM's are Unix times): only the offsets from the first count.
  const std::vector<double> stamps{1305031102.0, 1305031102.04, 1305031102.05, 1305031102.12};
  auto source = paced(std::make_unique<ListedFrames>(stamps));
  EXPECT_EQ(source->remaining(), stamps.size());
  const auto start = std::chrono::steady_clock::now();
  std::size_t n = 0;
  while (auto f = source->next()) {
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ASSERT_LT(n, stamps.size());
    EXPECT_EQ(f->index, n);  // in order, none dropped
    // A lower bound only (a loaded machine hands frames out later, never sooner).
    EXPECT_GE(elapsed, stamps[n] - stamps[0] - 1e-3) << "frame " << n;
    ++n;
  }
  EXPECT_EQ(n, stamps.size());
  EXPECT_EQ(source->skipped(), 3u);  // the wrapped source's count
}

TEST(PacedFrames, CountsTheFramesAskedForAFrameIntervalLate) {
  // Frames every 10 ms; the consumer dawdles past the next frame's time plus an interval before
  // asking for frames 1 and 2, so those two are late however loaded the machine is (a sleep
  // lasts at least its time), and frame 3, asked for at once, may be late on a busy machine.
  const std::vector<double> stamps{5.00, 5.01, 5.02, 5.03};
  auto source = paced(std::make_unique<ListedFrames>(stamps));
  ASSERT_TRUE(source->next());
  const auto start = std::chrono::steady_clock::now();  // no earlier than the pacer's start
  for (std::size_t k = 1; k <= 2; ++k) {
    std::this_thread::sleep_until(
        start + std::chrono::duration<double>(stamps[k] - stamps[0] + 0.01 + 0.005));
    ASSERT_TRUE(source->next());
  }
  ASSERT_TRUE(source->next());
  EXPECT_FALSE(source->next());
  EXPECT_GE(source->late(), 2u);
  EXPECT_LE(source->late(), 3u);
}

// Frames 0..n-1; frame `bad` throws instead (an unreadable file the source cannot skip).
class FailingFrames final : public FrameSource {
 public:
  FailingFrames(std::size_t n, std::size_t bad) : n_(n), bad_(bad) {}
  std::optional<Frame> next() override {
    if (next_ == n_) return std::nullopt;
    if (next_ == bad_) throw Error("frame " + std::to_string(bad_) + " is broken");
    Frame f;
    f.index = next_++;
    return f;
  }
  std::size_t remaining() const override { return n_ - next_; }

 private:
  std::size_t n_, bad_, next_ = 0;
};

TEST(ReadAheadFrames, HandsOutTheSameFramesInOrderWithTheSourcesCounts) {
  std::vector<double> stamps(50);
  for (std::size_t i = 0; i < stamps.size(); ++i)
    stamps[i] = 0.1 * static_cast<double>(i);
  auto source = read_ahead(std::make_unique<ListedFrames>(stamps), 4);
  EXPECT_EQ(source->remaining(), stamps.size());
  std::size_t n = 0;
  while (auto f = source->next()) {
    ASSERT_LT(n, stamps.size());
    EXPECT_EQ(f->index, n);
    EXPECT_DOUBLE_EQ(f->timestamp, stamps[n]);
    ++n;
  }
  EXPECT_EQ(n, stamps.size());
  EXPECT_FALSE(source->next());  // the end stays the end
  EXPECT_EQ(source->skipped(), 3u);
}

TEST(ReadAheadFrames, ASourcesErrorComesOutWhereItsFrameWouldHaveBeen) {
  auto source = read_ahead(std::make_unique<FailingFrames>(10, 6), 2);
  for (std::size_t i = 0; i < 6; ++i) {
    const auto f = source->next();
    ASSERT_TRUE(f);
    EXPECT_EQ(f->index, i);
  }
  EXPECT_THROW(source->next(), Error);
  EXPECT_FALSE(source->next());
}

// Endless frames, counting how many were read (the count outlives the source).
class CountedFrames final : public FrameSource {
 public:
  explicit CountedFrames(std::shared_ptr<std::atomic<std::size_t>> reads)
      : reads_(std::move(reads)) {}
  std::optional<Frame> next() override {
    Frame f;
    f.index = reads_->fetch_add(1);
    return f;
  }

 private:
  std::shared_ptr<std::atomic<std::size_t>> reads_;
};

TEST(ReadAheadFrames, LeavingEarlyStopsTheReader) {
  // The reader is blocked on a full queue when the consumer goes: the destructor must wake it,
  // and it must read no further (an endless source would otherwise hang the destructor).
  auto reads = std::make_shared<std::atomic<std::size_t>>(0);
  auto source = read_ahead(std::make_unique<CountedFrames>(reads), 2);
  EXPECT_EQ(source->remaining(), 0u);  // an endless source has no count
  ASSERT_TRUE(source->next());
  source.reset();
  // One handed out, two queued, one held by the blocked push.
  EXPECT_LE(reads->load(), 4u);
}

}  // namespace
}  // namespace coloc::dataset
