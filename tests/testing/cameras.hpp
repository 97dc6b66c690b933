#pragma once
// Cameras of the shared real recordings, for tests.

#include "slam/core/camera.hpp"

namespace coloc::testing {

// TUM RGB-D fr1 (Kinect v1), as ../shared/data/README.md states it; depth is registered to it.
inline PinholeCamera tum_fr1_camera() {
  return {640, 480, 517.3, 516.5, 318.6, 255.3, {0.2624, -0.9531, -0.0054, 0.0026, 1.1633}};
}

}  // namespace coloc::testing
