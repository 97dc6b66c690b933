#include "slam/map/keyframe_depth.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "slam/core/error.hpp"

namespace coloc::slam::map {

void KeyframeDepth::check() const {
  if (width < 1 || width > kMaxSide || height < 1 || height > kMaxSide)
    throw Error("KeyframeDepth: " + std::to_string(width) + " x " + std::to_string(height) +
                    " pixels, not in 1.." + std::to_string(kMaxSide),
                {.field = "width"});
  if (factor < 1 || factor > kMaxFactor)
    throw Error("KeyframeDepth: factor " + std::to_string(factor) + " not in 1.." +
                    std::to_string(kMaxFactor),
                {.field = "factor"});
  if (millimetres.size() != static_cast<std::size_t>(width) * static_cast<std::size_t>(height))
    throw Error("KeyframeDepth: " + std::to_string(millimetres.size()) + " values for " +
                    std::to_string(width) + " x " + std::to_string(height) + " pixels",
                {.field = "millimetres"});
}

KeyframeDepth downsample_depth(const float* metres, int width, int height, std::size_t row_stride,
                               int factor) {
  if (factor < 1 || factor > KeyframeDepth::kMaxFactor)
    throw Error("downsample_depth: factor " + std::to_string(factor) + " not in 1.." +
                    std::to_string(KeyframeDepth::kMaxFactor),
                {.field = "factor"});
  KeyframeDepth out;
  out.factor = factor;
  out.width = width / factor;
  out.height = height / factor;
  if (out.width < 1 || out.height < 1)
    throw Error("downsample_depth: a " + std::to_string(width) + " x " + std::to_string(height) +
                    " image is smaller than one block of " + std::to_string(factor),
                {.field = "factor"});
  out.millimetres.assign(static_cast<std::size_t>(out.width) * static_cast<std::size_t>(out.height),
                         0);
  std::vector<std::uint16_t> block;
  block.reserve(static_cast<std::size_t>(factor) * static_cast<std::size_t>(factor));
  for (int v = 0; v < out.height; ++v) {
    for (int u = 0; u < out.width; ++u) {
      block.clear();
      for (int y = v * factor; y < (v + 1) * factor; ++y) {
        const float* row = metres + static_cast<std::size_t>(y) * row_stride;
        for (int x = u * factor; x < (u + 1) * factor; ++x) {
          const double mm = std::round(1e3 * static_cast<double>(row[x]));
          if (mm >= 1.0 && mm <= 65535.0) block.push_back(static_cast<std::uint16_t>(mm));
        }
      }
      if (block.empty()) continue;
      // The lower median of an even count: a depth the sensor measured, never an average.
      const auto mid = block.begin() + static_cast<std::ptrdiff_t>((block.size() - 1) / 2);
      std::nth_element(block.begin(), mid, block.end());
      out.millimetres[static_cast<std::size_t>(v) * static_cast<std::size_t>(out.width) +
                      static_cast<std::size_t>(u)] = *mid;
    }
  }
  return out;
}

}  // namespace coloc::slam::map
