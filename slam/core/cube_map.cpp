#include "slam/core/cube_map.hpp"

#include <utility>

namespace coloc {

const char* cube_face_name(int face) {
  static constexpr std::array<const char*, kCubeFaces> kNames{"+x", "-x", "+y", "-y", "+z", "-z"};
  return kNames.at(static_cast<std::size_t>(face));
}

std::array<SO3, kCubeFaces> cube_face_rotations() {
  // (viewing direction, image-down direction) in the station frame.
  const std::array<std::pair<Eigen::Vector3d, Eigen::Vector3d>, kCubeFaces> faces{{
      {Eigen::Vector3d::UnitX(), -Eigen::Vector3d::UnitZ()},
      {-Eigen::Vector3d::UnitX(), -Eigen::Vector3d::UnitZ()},
      {Eigen::Vector3d::UnitY(), -Eigen::Vector3d::UnitZ()},
      {-Eigen::Vector3d::UnitY(), -Eigen::Vector3d::UnitZ()},
      {Eigen::Vector3d::UnitZ(), -Eigen::Vector3d::UnitX()},
      {-Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitX()},
  }};
  std::array<SO3, kCubeFaces> out;
  for (std::size_t i = 0; i < out.size(); ++i) {
    const auto& [z, y] = faces[i];
    Eigen::Matrix3d r;
    r.col(0) = y.cross(z);
    r.col(1) = y;
    r.col(2) = z;
    out[i] = SO3::from_matrix(r);
  }
  return out;
}

PinholeCamera cube_face_camera(int size) {
  PinholeCamera c;
  c.width = c.height = size;
  c.fx = c.fy = 0.5 * size;
  c.cx = c.cy = 0.5 * (size - 1);
  return c;
}

}  // namespace coloc
