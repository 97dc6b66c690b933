#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <thread>
#include <unordered_set>

#include "slam/core/error.hpp"
#include "slam/core/ids.hpp"
#include "slam/core/progress.hpp"
#include "slam/core/timing.hpp"

namespace coloc {
namespace {

TEST(Error, FormatsContext) {
  const Error e("not a number", {.file = "cam.yaml", .field = "Camera.fx", .line = 4});
  EXPECT_STREQ(e.what(), "cam.yaml:4: field 'Camera.fx': not a number");
  EXPECT_EQ(e.message(), "not a number");
  const Error f("bad checksum", {.file = "x.e57", .offset = 1024});
  EXPECT_STREQ(f.what(), "x.e57: at offset 1024: bad checksum");
}

TEST(Ids, StrongTypesHashAndIssue) {
  IdIssuer<KeyframeId> issuer;
  const KeyframeId a = issuer.next();
  const KeyframeId b = issuer.next();
  EXPECT_EQ(a.value(), 0u);
  EXPECT_LT(a, b);
  EXPECT_FALSE(KeyframeId().valid());
  std::unordered_set<KeyframeId> set{a, b, a};
  EXPECT_EQ(set.size(), 2u);
  issuer.continue_after(KeyframeId(41));
  EXPECT_EQ(issuer.next().value(), 42u);
  static_assert(!std::is_convertible_v<KeyframeId, MapPointId>);
}

TEST(Timing, QuantilesAndSummary) {
  const std::vector<double> v = {5, 1, 4, 2, 3};
  EXPECT_DOUBLE_EQ(quantile(v, 0.5), 3.0);
  EXPECT_DOUBLE_EQ(quantile(v, 0.0), 1.0);
  EXPECT_DOUBLE_EQ(quantile(v, 1.0), 5.0);
  EXPECT_DOUBLE_EQ(quantile(v, 0.25), 2.0);
  const SampleStats s = summarize(v);
  EXPECT_EQ(s.count, 5u);
  EXPECT_DOUBLE_EQ(s.mean, 3.0);
  EXPECT_DOUBLE_EQ(s.stddev, std::sqrt(2.0));
  EXPECT_DOUBLE_EQ(s.min, 1.0);
  EXPECT_DOUBLE_EQ(s.max, 5.0);
  Stopwatch w;
  EXPECT_GE(w.elapsed_ms(), 0.0);
}

// Thread CPU time advances while the thread computes and (nearly) stands still while it sleeps:
// the property the benchmarks rely on to exclude time other processes held the core.
TEST(Timing, ThreadCpuStopwatchCountsWorkNotSleep) {
  const ThreadCpuStopwatch cpu;
  volatile double sink = 0.0;
  while (cpu.elapsed_ms() < 2.0)
    sink = sink + 1.0;
  EXPECT_GE(cpu.elapsed_ms(), 2.0);
  const ThreadCpuStopwatch asleep;
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_LT(asleep.elapsed_ms(), 50.0);
}

TEST(Progress, NonTtyWritesOneLinePerDecile) {
  std::FILE* f = std::tmpfile();
  ASSERT_NE(f, nullptr);
  {
    Progress p("work", 100, false, f);
    for (int i = 0; i < 100; ++i)
      p.advance();
  }
  std::rewind(f);
  int lines = 0;
  char buf[256];
  std::string last;
  while (std::fgets(buf, sizeof(buf), f) != nullptr) {
    ++lines;
    last = buf;
  }
  std::fclose(f);
  EXPECT_EQ(lines, 11);  // 0 %..100 % in steps of ten, one line each
  EXPECT_NE(last.find("100%"), std::string::npos);
  EXPECT_NE(last.find("100/100"), std::string::npos);
}

}  // namespace
}  // namespace coloc
