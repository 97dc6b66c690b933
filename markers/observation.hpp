#pragma once
// One square fiducial seen in one image: what the detector produces and what SLAM keyframes
// store (and a map file saves). Eigen only, so the map and its file schema do not depend on the
// detector or on OpenCV's aruco module.
//
// Pixel convention: the origin is the centre of the top-left pixel (as slam/core/camera.hpp).
// Corner order (OpenCV's): the marker's own top-left, top-right, bottom-right, bottom-left corner,
// i.e. clockwise in the image when the marker is seen from its front. marker_pose.hpp maps this
// order to the marker frame.
#include <Eigen/Core>
#include <array>

namespace coloc::markers {

struct MarkerObservation {
  int id = -1;
  std::array<Eigen::Vector2d, 4> corners{};  // pixels, order as described above
  int image_width = 0;
  int image_height = 0;

  Eigen::Vector2d centre() const;
  double perimeter() const;  // pixels
};

}  // namespace coloc::markers
