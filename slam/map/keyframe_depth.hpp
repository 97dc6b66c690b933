#pragma once
// A keyframe's depth image, kept small: what registration without markers needs of the
// recording (the map's dense cloud, the surface BA's depth samples) when only the map file is
// at hand. Tracking fills it from the frame's depth image when the frame becomes a keyframe;
// slam/mapdb stores it (table keyframe_depth, schema 4). A plain value, no OpenCV: ~38 KB for
// a 640x480 frame at the default factor 4.
//
// Pixel (u, v) of the small image stands for the block of factor x factor full-resolution
// pixels starting at (factor u, factor v), and is placed at the full-resolution pixel
// (factor u + factor / 2, factor v + factor / 2) (full_pixel()). Its value is the median of the
// block's valid depths in millimetres (0: no valid depth in the block): the median, not the
// mean, so that a block across a depth edge takes one of the two surfaces rather than a point
// floating between them.
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace coloc::slam::map {

struct KeyframeDepth {
  // The largest side and factor a valid KeyframeDepth has (check()); a map file holding more is
  // damaged.
  static constexpr int kMaxSide = 8192;
  static constexpr int kMaxFactor = 64;

  int width = 0, height = 0;  // pixels of the small image
  int factor = 1;             // full-resolution pixels per small pixel, along each axis
  std::vector<std::uint16_t> millimetres;  // row-major, width x height; 0 = no depth

  // Metres at small pixel (u, v); 0 when invalid.
  double metres(int u, int v) const {
    return 1e-3 * millimetres[static_cast<std::size_t>(v) * static_cast<std::size_t>(width) +
                              static_cast<std::size_t>(u)];
  }
  // The full-resolution pixel small pixel (u, v) stands for.
  Eigen::Vector2d full_pixel(int u, int v) const {
    const int half = factor / 2;  // whole pixels: the block's middle pixel, as stored
    return {static_cast<double>(factor * u + half), static_cast<double>(factor * v + half)};
  }
  bool operator==(const KeyframeDepth&) const = default;
  // Throws coloc::Error naming the first invalid field (sides 1..kMaxSide, factor
  // 1..kMaxFactor, width x height values).
  void check() const;
};

// The depth image `metres` (width x height floats, row i starting at metres + i * row_stride,
// 0 or non-finite = invalid, as the RGB-D frames give it) downsampled by `factor`: blocks that
// do not fit whole at the right and bottom edges are dropped. Depths beyond 65.535 m are
// invalid. Throws coloc::Error for a factor outside 1..kMaxFactor or an image smaller than one
// block.
KeyframeDepth downsample_depth(const float* metres, int width, int height, std::size_t row_stride,
                               int factor);

}  // namespace coloc::slam::map
