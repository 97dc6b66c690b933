#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>

#include "slam/features/quadtree.hpp"

namespace coloc::slam::features {
namespace {

// A dense blob of strong corners in one corner of the image and weaker corners spread evenly:
// the quadtree must keep the spread ones (coverage), not the top-N by response.
std::vector<Candidate> blob_and_spread() {
  std::vector<Candidate> candidates;
  for (int i = 0; i < 400; ++i) {
    candidates.push_back({20.0f + static_cast<float>(i % 20), 20.0f + static_cast<float>(i / 20),
                          100.0f + static_cast<float>(i % 7)});
  }
  for (int gy = 0; gy < 6; ++gy) {
    for (int gx = 0; gx < 8; ++gx) {
      candidates.push_back(
          {40.0f + 75.0f * static_cast<float>(gx), 40.0f + 75.0f * static_cast<float>(gy), 10.0f});
    }
  }
  return candidates;
}

TEST(Quadtree, SpreadsOverTheImageInsteadOfTakingTheStrongest) {
  const auto candidates = blob_and_spread();
  const std::vector<int> selected = distribute_quadtree(candidates, 60, 0, 640, 0, 480);
  EXPECT_EQ(selected.size(), 60U);
  const auto spread =
      std::count_if(selected.begin(), selected.end(), [](int i) { return i >= 400; });
  // 48 spread candidates (one is inside the blob's region); nearly all must be kept.
  EXPECT_GE(spread, 44);
  EXPECT_TRUE(std::is_sorted(selected.begin(), selected.end()));
  EXPECT_EQ(std::adjacent_find(selected.begin(), selected.end()), selected.end());
}

TEST(Quadtree, KeepsEverythingBelowQuotaAndHandlesEdgeCases) {
  const auto candidates = blob_and_spread();
  EXPECT_EQ(distribute_quadtree(candidates, 10000, 0, 640, 0, 480).size(), candidates.size());
  EXPECT_TRUE(distribute_quadtree({}, 10, 0, 640, 0, 480).empty());
  EXPECT_TRUE(distribute_quadtree(candidates, 0, 0, 640, 0, 480).empty());
  // Candidates at one place cannot be separated: the strongest one is kept, without looping.
  const std::vector<Candidate> same(5, Candidate{10.0f, 10.0f, 1.0f});
  EXPECT_EQ(distribute_quadtree(same, 3, 0, 20, 0, 20), std::vector<int>{0});
}

TEST(Quadtree, KeepsTheStrongestOfEachCell) {
  // Two far-apart pairs, quota 2: one per pair, the stronger of each.
  const std::vector<Candidate> candidates = {
      {10, 10, 5}, {12, 11, 9}, {600, 400, 7}, {601, 402, 3}};
  EXPECT_EQ(distribute_quadtree(candidates, 2, 0, 640, 0, 480), (std::vector<int>{1, 2}));
}

}  // namespace
}  // namespace coloc::slam::features
