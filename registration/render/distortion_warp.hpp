#pragma once
// Private to the renderer: lens distortion as a post-warp. An ideal pinhole image (same fx fy,
// larger canvas covering every distorted pixel's ray) is rendered first, then resampled at the
// undistorted position of each distorted pixel.

#include <opencv2/core.hpp>
#include <vector>

#include "registration/render/renderer.hpp"

namespace coloc::registration::render {

class DistortionWarp {
 public:
  // The ideal camera to render for `camera`; rebuilds the maps when the camera changes.
  PinholeCamera prepare(const PinholeCamera& camera);
  // Resamples an ideal rendering (of the last prepared camera) into the distorted image.
  RenderResult apply(const RenderResult& ideal) const;

 private:
  // Relative cross difference of the four samples' inverse depths below which they are taken
  // as one plane (float rounding on a plane stays far below it).
  static constexpr float kPlanarTolerance = 1e-4f;
  // Depth and world point of distorted pixel (u, v) interpolated on the ideal image's surface;
  // false where the four neighbours are not one plane (an edge) or not all hit.
  bool interpolate(const RenderResult& ideal, int u, int v, float& depth, cv::Vec3f& point) const;

  PinholeCamera camera_;
  PinholeCamera ideal_;
  cv::Mat map_x_, map_y_;     // CV_32F, ideal-image coordinates of each distorted pixel
  std::vector<int> nearest_;  // ideal-image linear index of each distorted pixel, -1 outside
  bool valid_ = false;
};

}  // namespace coloc::registration::render
