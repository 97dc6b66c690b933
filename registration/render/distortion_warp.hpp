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
  PinholeCamera camera_;
  PinholeCamera ideal_;
  cv::Mat map_x_, map_y_;     // CV_32F, ideal-image coordinates of each distorted pixel
  std::vector<int> nearest_;  // ideal-image linear index of each distorted pixel, -1 outside
  bool valid_ = false;
};

}  // namespace coloc::registration::render
