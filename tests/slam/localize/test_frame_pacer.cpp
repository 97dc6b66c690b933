// The live-camera pacing and the bounded per-frame timing: pure bookkeeping, no clock.
#include <gtest/gtest.h>

#include <cmath>

#include "slam/core/error.hpp"
#include "slam/localize/frame_pacer.hpp"
#include "slam/localize/time_histogram.hpp"

namespace coloc::slam::localize {
namespace {

std::vector<double> frames_at(double first, double dt, int n) {
  std::vector<double> t;
  for (int i = 0; i < n; ++i)
    t.push_back(first + dt * i);
  return t;
}

TEST(FramePacer, AFastLocalizerWaitsForEachFrameAndDropsNone) {
  FramePacer pacer(frames_at(100.0, 0.1, 5));
  double clock = 0.0;
  for (std::size_t i = 0; i < 5; ++i) {
    const auto f = pacer.next(clock);
    ASSERT_TRUE(f);
    EXPECT_EQ(f->index, i);
    EXPECT_EQ(f->dropped, 0u);
    clock += f->wait_s + 0.02;  // waits for the frame, then works 20 ms
  }
  EXPECT_FALSE(pacer.next(clock));
  EXPECT_EQ(pacer.dropped(), 0u);
  EXPECT_EQ(pacer.processed(), 5u);
}

TEST(FramePacer, ASlowLocalizerTakesTheNewestFrameAndCountsTheRest) {
  FramePacer pacer(frames_at(0.0, 0.1, 10));
  auto f = pacer.next(0.0);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->index, 0u);
  // 0.35 s of work: frames 1, 2, 3 arrived meanwhile; 3 is taken, 1 and 2 dropped.
  f = pacer.next(0.35);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->index, 3u);
  EXPECT_EQ(f->dropped, 2u);
  EXPECT_DOUBLE_EQ(f->wait_s, 0.0);
  // Done early: waits for frame 4.
  f = pacer.next(0.36);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->index, 4u);
  EXPECT_NEAR(f->wait_s, 0.04, 1e-9);
  // Far behind at the end: the last frame, everything in between dropped.
  f = pacer.next(5.0);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->index, 9u);
  EXPECT_EQ(f->dropped, 4u);
  EXPECT_FALSE(pacer.next(6.0));
  EXPECT_EQ(pacer.dropped(), 6u);
  EXPECT_EQ(pacer.processed(), 4u);
}

TEST(FramePacer, RejectsTimeRunningBackwards) {
  EXPECT_THROW(FramePacer({0.0, 0.2, 0.1}), Error);
  EXPECT_FALSE(FramePacer({}).next(0.0));
}

TEST(TimeHistogram, QuantilesToTheBinWidthInFixedMemory) {
  TimeHistogram h;
  EXPECT_EQ(h.quantile(0.5), 0.0);
  for (int i = 1; i <= 100; ++i)
    h.add(i);  // 1 .. 100 ms
  EXPECT_EQ(h.count(), 100u);
  EXPECT_NEAR(h.quantile(0.5), 50.0, TimeHistogram::kBinMs);
  EXPECT_NEAR(h.quantile(0.99), 99.0, TimeHistogram::kBinMs);
  EXPECT_NEAR(h.mean(), 50.5, 1e-9);
  h.add(1000.0);  // beyond the range: the maximum
  EXPECT_EQ(h.max(), 1000.0);
  EXPECT_EQ(h.quantile(1.0), 1000.0);
  h.add(-1.0);
  h.add(std::nan(""));
  EXPECT_EQ(h.count(), 103u);
}

}  // namespace
}  // namespace coloc::slam::localize
