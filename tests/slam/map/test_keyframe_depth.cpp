// A keyframe's small depth image (slam/map/keyframe_depth.hpp): each block's median valid depth
// in millimetres, 0 for a block without one, and the full-resolution pixel each stands for.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "slam/core/error.hpp"
#include "slam/map/keyframe_depth.hpp"

namespace coloc::slam::map {
namespace {

TEST(KeyframeDepth, BlocksTakeTheMedianOfTheirValidDepths) {
  // 10 x 9 metres image, factor 4: 2 x 2 blocks (the last two columns and the last row are
  // left out), rows padded to a stride of 12 floats.
  constexpr int kWidth = 10, kHeight = 9, kStride = 12;
  std::vector<float> image(static_cast<std::size_t>(kStride * kHeight), 1.0f);
  auto at = [&](int x, int y) -> float& {
    return image[static_cast<std::size_t>(y * kStride + x)];
  };
  // Block (0, 0): 16 values 1.000 .. 1.015 m, shuffled by position; the lower median is 1.007.
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x)
      at(x, y) = 1.0f + 0.001f * static_cast<float>((x * 4 + y * 7) % 16);
  // Block (1, 0): nothing valid (0, negative, NaN, infinity, beyond 65.535 m).
  const float invalid[] = {0.0f, -1.0f, std::numeric_limits<float>::quiet_NaN(),
                           std::numeric_limits<float>::infinity(), 70.0f};
  for (int y = 0; y < 4; ++y)
    for (int x = 4; x < 8; ++x)
      at(x, y) = invalid[(x + y) % 5];
  // Block (0, 1): a depth edge, 7 pixels at 0.5 m, 9 at 3 m: the median is a surface, 3 m.
  for (int y = 4; y < 8; ++y)
    for (int x = 0; x < 4; ++x)
      at(x, y) = (y - 4) * 4 + x < 7 ? 0.5f : 3.0f;
  // Block (1, 1): one valid pixel among invalid ones.
  for (int y = 4; y < 8; ++y)
    for (int x = 4; x < 8; ++x)
      at(x, y) = 0.0f;
  at(6, 5) = 2.2224f;  // rounds to 2222 mm
  // Outside every block: must not matter.
  at(9, 0) = 9.0f;
  at(0, 8) = 9.0f;

  const KeyframeDepth d = downsample_depth(image.data(), kWidth, kHeight, kStride, 4);
  EXPECT_NO_THROW(d.check());
  EXPECT_EQ(d.width, 2);
  EXPECT_EQ(d.height, 2);
  EXPECT_EQ(d.factor, 4);
  EXPECT_EQ(d.millimetres, (std::vector<std::uint16_t>{1007, 0, 3000, 2222}));
  EXPECT_DOUBLE_EQ(d.metres(0, 1), 3.0);
  EXPECT_EQ(d.full_pixel(0, 0), Eigen::Vector2d(2, 2));
  EXPECT_EQ(d.full_pixel(1, 1), Eigen::Vector2d(6, 6));
}

TEST(KeyframeDepth, FactorOneKeepsEveryPixel) {
  const std::vector<float> image = {0.25f, 0.0f, 1.5f, 65.535f};
  const KeyframeDepth d = downsample_depth(image.data(), 2, 2, 2, 1);
  EXPECT_EQ(d.millimetres, (std::vector<std::uint16_t>{250, 0, 1500, 65535}));
  EXPECT_EQ(d.full_pixel(1, 1), Eigen::Vector2d(1, 1));
}

TEST(KeyframeDepth, BadFactorsAndSizesAreErrors) {
  const std::vector<float> image(16, 1.0f);
  EXPECT_THROW(downsample_depth(image.data(), 4, 4, 4, 0), Error);
  EXPECT_THROW(downsample_depth(image.data(), 4, 4, 4, 65), Error);
  EXPECT_THROW(downsample_depth(image.data(), 4, 4, 4, 8), Error);  // smaller than one block
  KeyframeDepth d = downsample_depth(image.data(), 4, 4, 4, 2);
  d.millimetres.pop_back();
  EXPECT_THROW(d.check(), Error);
  d = downsample_depth(image.data(), 4, 4, 4, 2);
  d.factor = 0;
  EXPECT_THROW(d.check(), Error);
  d.factor = 2;
  d.width = KeyframeDepth::kMaxSide + 1;
  EXPECT_THROW(d.check(), Error);
}

}  // namespace
}  // namespace coloc::slam::map
