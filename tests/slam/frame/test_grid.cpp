// The frame's keypoint grid (compressed rows: one start per cell, one index per keypoint):
// every keypoint within the bounds is in exactly its cell, cells list keypoints in ascending
// order, and features_in_area finds exactly what a scan of all keypoints finds.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "slam/frame/frame.hpp"

namespace coloc::slam::frame {
namespace {

std::shared_ptr<const FrameGeometry> geometry() {
  auto g = std::make_shared<FrameGeometry>();
  g->fx = g->fy = 500.0;
  g->cx = 320.0;
  g->cy = 240.0;
  g->bf = 40.0;
  g->close_depth = 3.0;
  g->max_x = 640.0;
  g->max_y = 480.0;
  g->scale_factors = {1.0f, 1.2f, 1.44f};
  g->level_sigma2 = {1.0f, 1.44f, 2.0736f};
  return g;
}

// `n` keypoints spread over the image and a margin outside it (those are in no cell).
Frame random_frame(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> x(-20.0f, 660.0f), y(-20.0f, 500.0f);
  std::uniform_int_distribution<int> level(0, 2);
  features::OrbFeatures f;
  for (std::size_t i = 0; i < n; ++i) {
    features::Keypoint kp;
    kp.x = kp.ux = x(rng);
    kp.y = kp.uy = y(rng);
    kp.level = level(rng);
    f.keypoints.push_back(kp);
  }
  f.descriptors.resize(n);
  return Frame(FrameId(1), 0.0, std::move(f), std::vector<float>(n, -1.0f),
               std::vector<float>(n, -1.0f), geometry());
}

TEST(FrameGrid, EveryKeypointInItsCellInAscendingOrder) {
  const Frame frame = random_frame(2000, 1);
  const FrameGeometry& g = frame.geometry();
  const auto& starts = frame.grid_starts();
  const auto& keypoints = frame.grid_keypoints();
  const auto cells = static_cast<std::size_t>(g.grid_cols * g.grid_rows);
  ASSERT_EQ(starts.size(), cells + 1);
  EXPECT_EQ(starts.front(), 0u);
  EXPECT_EQ(starts.back(), keypoints.size());
  std::vector<int> seen(frame.size(), 0);
  for (std::size_t cell = 0; cell < cells; ++cell) {
    ASSERT_LE(starts[cell], starts[cell + 1]);
    for (std::uint32_t k = starts[cell]; k < starts[cell + 1]; ++k) {
      const std::uint32_t i = keypoints[k];
      if (k > starts[cell]) {
        EXPECT_LT(keypoints[k - 1], i) << "cell " << cell;
      }
      const auto& kp = frame.features.keypoints[i];
      const auto c = static_cast<std::size_t>(std::floor(kp.ux * g.grid_cols / g.max_x));
      const auto r = static_cast<std::size_t>(std::floor(kp.uy * g.grid_rows / g.max_y));
      EXPECT_EQ(r * static_cast<std::size_t>(g.grid_cols) + c, cell) << "keypoint " << i;
      ++seen[i];
    }
  }
  std::size_t outside = 0;
  for (std::size_t i = 0; i < frame.size(); ++i) {
    const auto& kp = frame.features.keypoints[i];
    const bool inside = kp.ux >= 0.0f && kp.ux < 640.0f && kp.uy >= 0.0f && kp.uy < 480.0f;
    EXPECT_EQ(seen[i], inside ? 1 : 0) << "keypoint " << i;
    outside += inside ? 0 : 1;
  }
  EXPECT_GT(outside, 0u);  // the test covers keypoints outside the bounds
}

TEST(FrameGrid, AreaSearchFindsWhatAScanFinds) {
  const Frame frame = random_frame(2000, 2);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> x(-30.0, 670.0), y(-30.0, 510.0), radius(0.5, 60.0);
  for (int q = 0; q < 300; ++q) {
    const double qx = x(rng), qy = y(rng), r = radius(rng);
    const int min_level = q % 3, max_level = q % 2 ? -1 : 1;
    std::vector<std::size_t> scan;
    for (std::size_t i = 0; i < frame.size(); ++i) {
      const auto& kp = frame.features.keypoints[i];
      if (kp.ux < 0.0f || kp.ux >= 640.0f || kp.uy < 0.0f || kp.uy >= 480.0f) continue;
      if (kp.level < min_level || (max_level >= 0 && kp.level > max_level)) continue;
      const double dx = kp.ux - qx, dy = kp.uy - qy;
      if (dx * dx + dy * dy <= r * r) scan.push_back(i);
    }
    std::vector<std::size_t> found = frame.features_in_area(qx, qy, r, min_level, max_level);
    std::sort(found.begin(), found.end());
    EXPECT_EQ(found, scan) << "query " << q;
  }
}

TEST(FrameGrid, DefaultFrameAndEmptyFrame) {
  EXPECT_TRUE(Frame().grid_starts().empty());
  const Frame empty = random_frame(0, 3);
  EXPECT_TRUE(empty.grid_keypoints().empty());
  EXPECT_TRUE(empty.features_in_area(320.0, 240.0, 100.0).empty());
}

}  // namespace
}  // namespace coloc::slam::frame
