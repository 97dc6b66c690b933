// parallel_for: every item exactly once whatever the thread count, and a failure rethrown on the
// calling thread after every worker joined.
#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <vector>

#include "slam/core/parallel.hpp"

namespace coloc {
namespace {

TEST(ParallelFor, RunsEveryItemOnce) {
  for (const int threads : {0, 1, 2, 7}) {
    for (const std::size_t n : {0u, 1u, 3u, 1000u}) {
      std::vector<std::atomic<int>> runs(n);
      parallel_for(n, threads, [&](std::size_t i) { ++runs[i]; });
      for (std::size_t i = 0; i < n; ++i)
        EXPECT_EQ(runs[i].load(), 1) << "threads " << threads << ", n " << n << ", item " << i;
    }
  }
}

TEST(ParallelFor, RethrowsTheFirstFailureAfterJoining) {
  try {
    parallel_for(100, 2, [&](std::size_t i) {
      if (i == 10) throw std::runtime_error("item 10");
    });
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "item 10");
  }
}

TEST(ParallelFor, WorkerCountDefaultsToTheCores) {
  EXPECT_GE(worker_count(0), 1);
  EXPECT_EQ(worker_count(3), 3);
}

}  // namespace
}  // namespace coloc
