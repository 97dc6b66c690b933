#pragma once
// Depth registered to the colour image, so that SLAM gets RGB-D as TUM provides it: every depth
// pixel is lifted with the depth camera, moved by color_from_depth and projected into the colour
// camera (with its distortion); where several land on one colour pixel the nearest wins.
//
// The rays of the depth pixels are computed once per camera pair (DepthRegistrar), so one frame
// costs a multiply-add and a projection per pixel. Not thread-safe: one registrar per thread.
#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <vector>

#include "slam/core/camera.hpp"
#include "slam/core/se3.hpp"

namespace coloc::capture {

class DepthRegistrar {
 public:
  // Depth intrinsics must be undistorted (D4xx depth is rectified); colour may have Brown
  // distortion. Throws coloc::Error when depth has distortion or a size is zero.
  DepthRegistrar(const PinholeCamera& depth, const PinholeCamera& color,
                 const SE3& color_from_depth);

  // CV_16UC1 raw depth (units as given, 0 = invalid) -> CV_16UC1 in the colour image's size and
  // the same units. `units_per_metre` turns raw values into metres for the projection.
  cv::Mat register_raw(const cv::Mat& depth_raw, double units_per_metre) const;

 private:
  void project_row(const std::uint16_t* raw, int y, float units, std::int32_t* target,
                   std::uint16_t* value) const;

  PinholeCamera depth_, color_;
  std::vector<float> ray_x_, ray_y_;  // undistorted depth rays (z = 1), per pixel
  float r_[9], t_[3];
};

}  // namespace coloc::capture
