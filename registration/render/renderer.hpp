#pragma once
// Offscreen renderer on OSMesa (Mesa's software rasterizer: no window, no GPU). It draws a
// TexturedMesh and/or a PointCloud through coloc's pinhole camera model and returns colour,
// metric depth and the world point behind every pixel.
//
// Conventions: camera frame x right, y down, z forward; pixel (u, v) has its centre at integer
// coordinates (as slam/core/camera.hpp), so a world point rendered at pixel (u, v) projects back
// to (u, v) with PinholeCamera::project. Lens distortion is applied as a post-warp of an ideal
// pinhole rendering with the same fx fy: colour is resampled bilinearly, depth/points/index take
// the nearest ideal sample (so under distortion the 3-D point behind a pixel projects to within
// half a pixel of it; without distortion to within float precision).
//
// Determinism: the same inputs give bit-identical outputs (llvmpipe rasterizes in fixed tiles).
// Thread-safety: one Renderer per thread; a Renderer makes its own context current on each call,
// so several Renderers may be used from one thread in turn.

#include <memory>
#include <opencv2/core.hpp>

#include "registration/render/scene.hpp"
#include "slam/core/camera.hpp"
#include "slam/core/se3.hpp"

namespace coloc::registration::render {

struct RenderOptions {
  double near_plane = 0.05;  // metres; nearer surfaces are clipped
  double far_plane = 200.0;  // metres
  // Odd supersampling factor for colour (1, 3, 5): colour is the box average of s x s samples;
  // depth, points and index come from the sample at the pixel centre, so they stay exact.
  int supersample = 1;
  std::array<std::uint8_t, 3> background{0, 0, 0};  // RGB where nothing is hit
  int anisotropy = 1;  // texture anisotropic filtering (1 = off; 4 costs ~50 % more time)
  // Point clouds are drawn by cells of this side (metres) that the view can reach
  // (cloud_cells.hpp); 0 draws every point each time. The image is the same either way.
  double cull_cell = 1.0;

  void check() const;  // throws coloc::Error naming the bad field
};

// What to draw (bit mask).
enum class Layer : unsigned { kMesh = 1u, kPoints = 2u, kAll = 3u };

struct RenderResult {
  cv::Mat colour;  // CV_8UC3, RGB order
  cv::Mat depth;   // CV_32F, metres along the optical axis (z); 0 where nothing was hit
  cv::Mat points;  // CV_32FC3, world frame, metres; NaN where nothing was hit
  // CV_32S: index of the point (point-cloud splat) behind the pixel, or -1 (mesh or nothing).
  cv::Mat index;
};

class Renderer {
 public:
  explicit Renderer(RenderOptions options = {});
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;
  Renderer(Renderer&&) noexcept;
  Renderer& operator=(Renderer&&) noexcept;

  // Replace the mesh / point cloud (uploaded once, drawn by every render call).
  void set_mesh(const TexturedMesh& mesh);
  void set_point_cloud(const PointCloud& cloud);
  void clear_mesh();
  void clear_point_cloud();

  // Renders at the pose cam_from_world. The camera must be a PinholeCamera with positive size
  // (throws coloc::Error otherwise).
  RenderResult render(const PinholeCamera& camera, const SE3& cam_from_world,
                      Layer layers = Layer::kAll);

  const RenderOptions& options() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace coloc::registration::render
