#include <gtest/gtest.h>

#include <cmath>

#include "slam/core/cube_map.hpp"

namespace coloc {
namespace {

TEST(CubeMap, FacesTileTheSphere) {
  const auto faces = cube_face_rotations();
  const PinholeCamera cam = cube_face_camera(64);
  for (const SO3& f : faces)
    EXPECT_NEAR(f.matrix().determinant(), 1.0, 1e-12);
  // Every direction falls inside exactly one face (directions off the face boundaries).
  for (int k = 0; k < 200; ++k) {
    const Eigen::Vector3d d(std::sin(k * 1.7) + 0.013, std::cos(k * 2.3), std::sin(k * 0.37));
    int inside = 0;
    for (const SO3& station_from_face : faces) {
      const Eigen::Vector3d p = station_from_face.inverse() * d;
      if (p.z() <= 0) continue;
      if (in_image(cam, cam.project(p), -0.5)) ++inside;
    }
    EXPECT_EQ(inside, 1) << k;
  }
}

TEST(CubeMap, NamesAndCamera) {
  EXPECT_STREQ(cube_face_name(0), "+x");
  EXPECT_STREQ(cube_face_name(5), "-z");
  EXPECT_THROW(cube_face_name(6), std::out_of_range);
  const PinholeCamera c = cube_face_camera(512);
  EXPECT_EQ(c.width, 512);
  EXPECT_DOUBLE_EQ(c.fx, 256.0);
  EXPECT_DOUBLE_EQ(c.cx, 255.5);
  // The +x face looks along +x with image-down = -z (the scanner's z is up).
  const SO3 r = cube_face_rotations()[0];
  EXPECT_LT((r * Eigen::Vector3d::UnitZ() - Eigen::Vector3d::UnitX()).norm(), 1e-12);
  EXPECT_LT((r * Eigen::Vector3d::UnitY() + Eigen::Vector3d::UnitZ()).norm(), 1e-12);
}

}  // namespace
}  // namespace coloc
