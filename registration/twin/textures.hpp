#pragma once
// Procedural, feature-rich textures for the digital twin. Every texture is a pure function of
// its kind and a seed (std::mt19937_64 plus OpenCV drawing, no global RNG), so the same seed
// gives the same pixels on every machine.

#include <cstdint>
#include <opencv2/core.hpp>

namespace coloc::registration::twin {

enum class TextureKind {
  kPlaster,  // light wall paint with stains, posters, notices and pin-board clutter
  kBrick,    // brick bond with mortar and per-brick tone
  kWood,     // grain and planks (floors, furniture)
  kCarpet,   // speckled floor with tile seams
  kCeiling,  // acoustic ceiling tiles with lights
  kFabric,   // bold patterned cloth (sofas, curtains)
  kShelf,    // book spines and boxes
};

// A size x size RGB (CV_8UC3, RGB order) texture that tiles (wraps) horizontally and vertically.
cv::Mat make_texture(TextureKind kind, int size, std::uint64_t seed);

// The ArUco marker `id` of `dictionary` (an OpenCV predefined dictionary id, e.g.
// cv::aruco::DICT_4X4_50) as an RGB image: the black-bordered code of `cells` x `cells` modules
// (cells = marker bits + 2) surrounded by a white margin of `margin_cells` modules, each module
// `module_pixels` wide. Throws coloc::Error for an id outside the dictionary.
cv::Mat make_marker_texture(int dictionary, int id, int module_pixels, int margin_cells);
int marker_bits(int dictionary);

}  // namespace coloc::registration::twin
