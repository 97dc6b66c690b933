#pragma once
// The cube-map convention shared by whoever writes a laser station's six images (the twin's
// scanner) and whoever reads them (marker detection in the scan): one definition, so the two
// cannot drift apart. Faces look along +x, -x, +y, -y, +z, -z of the station (panorama) frame,
// each a 90-degree pinhole camera of size x size pixels.
#include <array>

#include "slam/core/camera.hpp"
#include "slam/core/so3.hpp"

namespace coloc {

inline constexpr int kCubeFaces = 6;

// "+x", "-x", "+y", "-y", "+z", "-z".
const char* cube_face_name(int face);

// station_from_face rotation of each face, in the order above. The face camera's z is its
// viewing direction; its image-down axis (y) is -z of the station for the four side faces.
std::array<SO3, kCubeFaces> cube_face_rotations();

// f = size / 2, principal point at the image centre ((size - 1) / 2).
PinholeCamera cube_face_camera(int size);

}  // namespace coloc
