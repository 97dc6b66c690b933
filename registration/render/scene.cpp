#include "registration/render/scene.hpp"

#include <string>

#include "slam/core/error.hpp"

namespace coloc::registration::render {

std::size_t TexturedMesh::triangle_count() const {
  std::size_t n = 0;
  for (const auto& p : parts)
    n += p.indices.size() / 3;
  return n;
}

void TexturedMesh::check() const {
  if (uvs.size() != vertices.size()) {
    throw Error("mesh: uvs and vertices differ in size", {.field = "uvs"});
  }
  if (tints.size() != vertices.size()) {
    throw Error("mesh: tints and vertices differ in size", {.field = "tints"});
  }
  for (std::size_t i = 0; i < parts.size(); ++i) {
    const Part& p = parts[i];
    const std::string field = "parts[" + std::to_string(i) + "]";
    if (p.indices.size() % 3 != 0) {
      throw Error("mesh: index count is not a multiple of 3", {.field = field});
    }
    if (p.texture >= static_cast<int>(textures.size()) || p.texture < -1) {
      throw Error("mesh: texture id out of range", {.field = field + ".texture"});
    }
    for (std::uint32_t idx : p.indices) {
      if (idx >= vertices.size()) {
        throw Error("mesh: vertex index out of range", {.field = field + ".indices"});
      }
    }
  }
  for (std::size_t i = 0; i < textures.size(); ++i) {
    const cv::Mat& t = textures[i];
    if (t.empty() || t.type() != CV_8UC3) {
      throw Error("mesh: texture is not a non-empty CV_8UC3 image",
                  {.field = "textures[" + std::to_string(i) + "]"});
    }
  }
}

void PointCloud::check() const {
  if (colours.size() != points.size()) {
    throw Error("point cloud: colours and points differ in size", {.field = "colours"});
  }
  if (!(splat_size > 0.0f))
    throw Error("point cloud: splat_size must be > 0", {.field = "splat_size"});
  if (!splat_sizes.empty() && splat_sizes.size() != points.size())
    throw Error("point cloud: splat_sizes and points differ in size", {.field = "splat_sizes"});
  for (float v : splat_sizes) {
    if (!(v > 0.0f)) throw Error("point cloud: a splat size is not > 0", {.field = "splat_sizes"});
  }
  if (!(max_splat_pixels >= 1.0f)) {
    throw Error("point cloud: max_splat_pixels must be >= 1", {.field = "max_splat_pixels"});
  }
}

}  // namespace coloc::registration::render
