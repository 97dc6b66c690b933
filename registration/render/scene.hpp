#pragma once
// What the offscreen renderer draws: textured triangle meshes and coloured point clouds, both in
// one "world" frame (metres). Plain values; the renderer copies them to its GL buffers.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

namespace coloc::registration::render {

// A triangle mesh whose triangles are grouped into parts, one texture per part.
struct TexturedMesh {
  struct Part {
    int texture = -1;                    // index into `textures`; -1 draws the vertex tint only
    std::vector<std::uint32_t> indices;  // 3 per triangle, into the vertex arrays
  };
  std::vector<Eigen::Vector3f> vertices;  // world frame, metres
  std::vector<Eigen::Vector2f> uvs;       // texture coordinates (u right, v down in the image)
  std::vector<Eigen::Vector3f> tints;     // per-vertex colour factor in [0, 1] (baked shading)
  std::vector<Part> parts;
  std::vector<cv::Mat> textures;  // CV_8UC3, RGB order; mipmapped, bilinear, repeat-wrapped

  std::size_t triangle_count() const;
  // Throws coloc::Error naming the inconsistent field (array sizes, indices, texture ids).
  void check() const;
};

// A coloured point cloud drawn as square splats whose side is `splat_size` metres at the point,
// so that a cloud sampled every splat_size metres shows closed surfaces.
struct PointCloud {
  std::vector<Eigen::Vector3f> points;               // world frame, metres
  std::vector<std::array<std::uint8_t, 3>> colours;  // RGB, one per point
  float splat_size = 0.01f;                          // metres
  // Per-point splat side (metres), one per point, overriding splat_size when not empty: a scan
  // is sparser far from its station, so its splats must grow with the range there.
  std::vector<float> splat_sizes;
  float max_splat_pixels = 64.0f;  // upper bound on the on-screen size

  void check() const;
};

}  // namespace coloc::registration::render
