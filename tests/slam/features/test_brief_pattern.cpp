#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <set>

#include "slam/features/brief_pattern.hpp"
#include "slam/features/orb_extractor.hpp"

namespace coloc::slam::features {
namespace {

TEST(BriefPattern, StaysInsideTheDiscAtEveryAngleAndHasDistinctPairs) {
  const BriefPattern pattern;
  for (int bin = 0; bin < BriefPattern::kAngleBins; ++bin) {
    const BriefPattern::Offset* o = pattern.rotated(bin);
    for (int i = 0; i < 2 * BriefPattern::kPairs; ++i) {
      EXPECT_LE(std::hypot(o[i].dx, o[i].dy), BriefPattern::kRadius + 0.75) << bin << " " << i;
    }
  }
  const BriefPattern::Offset* o = pattern.rotated(0);
  std::set<std::array<int, 4>> pairs;
  for (int i = 0; i < BriefPattern::kPairs; ++i) {
    EXPECT_FALSE(o[2 * i].dx == o[2 * i + 1].dx && o[2 * i].dy == o[2 * i + 1].dy);
    pairs.insert({o[2 * i].dx, o[2 * i].dy, o[2 * i + 1].dx, o[2 * i + 1].dy});
  }
  EXPECT_GT(pairs.size(), 250U);
  // A quarter turn maps (x, y) to (-y, x) exactly.
  const BriefPattern::Offset* q = pattern.rotated(BriefPattern::kAngleBins / 4);
  for (int i = 0; i < 2 * BriefPattern::kPairs; ++i) {
    EXPECT_EQ(q[i].dx, -o[i].dy);
    EXPECT_EQ(q[i].dy, o[i].dx);
  }
}

TEST(BriefPattern, AngleBinsWrapAround) {
  const auto two_pi = static_cast<float>(2.0 * std::numbers::pi);
  EXPECT_EQ(BriefPattern::angle_bin(0.0f), 0);
  EXPECT_EQ(BriefPattern::angle_bin(two_pi), 0);
  EXPECT_EQ(BriefPattern::angle_bin(two_pi - 0.001f), 0);
  EXPECT_EQ(BriefPattern::angle_bin(two_pi / 4), BriefPattern::kAngleBins / 4);
  EXPECT_EQ(BriefPattern::angle_bin(-two_pi / 4), 3 * BriefPattern::kAngleBins / 4);
}

TEST(GridCoverage, CountsCellsWithAKeypoint) {
  std::vector<Keypoint> keypoints = {{.x = 1, .y = 1}, {.x = 2, .y = 2}, {.x = 639, .y = 479}};
  EXPECT_DOUBLE_EQ(grid_coverage(keypoints, 640, 480, 16, 12), 2.0 / 192.0);
  EXPECT_DOUBLE_EQ(grid_coverage({}, 640, 480), 0.0);
  EXPECT_DOUBLE_EQ(grid_coverage(keypoints, 0, 480), 0.0);
}

}  // namespace
}  // namespace coloc::slam::features
