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
// so several Renderers may be used from one thread in turn. Renderers on several threads may
// draw one SharedPointCloud: the cloud is prepared and held once, whatever the thread count.

#include <cstddef>
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

// A point cloud prepared once for drawing (grouped into cells of RenderOptions::cull_cell, one
// GL vertex buffer in an OSMesa share group of its own) and drawn by every Renderer made with
// it, on any thread. Immutable after construction. Its memory, ~24 B per point (bytes()), is
// held once: with a cloud per Renderer a site's 38 M points cost ~1.5 GB per render thread.
// The PointCloud given is not referenced after the constructor.
class SharedPointCloud {
 public:
  // Throws coloc::Error for an invalid cloud or options.
  explicit SharedPointCloud(const PointCloud& cloud, const RenderOptions& options = {});
  ~SharedPointCloud();
  SharedPointCloud(const SharedPointCloud&) = delete;
  SharedPointCloud& operator=(const SharedPointCloud&) = delete;

  std::size_t size() const;   // points
  std::size_t bytes() const;  // memory it holds: the GL buffer and the cells

 private:
  friend class Renderer;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

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
  // Draws `cloud` (not null) until set_point_cloud / clear_point_cloud; options.cull_cell is
  // the cloud's. The Renderer keeps the cloud alive.
  Renderer(RenderOptions options, std::shared_ptr<const SharedPointCloud> cloud);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;
  Renderer(Renderer&&) noexcept;
  Renderer& operator=(Renderer&&) noexcept;

  // Replace the mesh / point cloud (uploaded once, drawn by every render call; a cloud set here
  // is this Renderer's own, as a SharedPointCloud held by one Renderer).
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
