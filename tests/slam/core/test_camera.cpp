#include <gtest/gtest.h>

#include "slam/core/camera.hpp"
#include "tests/slam/core/numeric.hpp"

namespace coloc {
namespace {

using testing::numeric_jacobian;

// TUM fr1 (real lens, strong k3) and a EuRoC-like fisheye.
PinholeCamera tum_fr1() {
  return {640,
          480,
          517.306408,
          516.469215,
          318.643040,
          255.313989,
          {0.262383, -0.953104, -0.005358, 0.002628, 1.163314}};
}
KannalaBrandtCamera fisheye() {
  return {752,
          480,
          190.97847715128717,
          190.9733070521226,
          254.93170605935475,
          256.8974428996504,
          {0.0034823894022493434, 0.0007150348452162257, -0.0020532361418706202,
           0.00020293673591811182}};
}

std::vector<Eigen::Vector2d> pixel_grid(int w, int h, int step) {
  std::vector<Eigen::Vector2d> out;
  for (int y = 0; y < h; y += step) {
    for (int x = 0; x < w; x += step)
      out.emplace_back(x, y);
  }
  return out;
}

TEST(Camera, PinholeUnprojectProjectRoundTrip) {
  const Camera cam = tum_fr1();
  for (const auto& px : pixel_grid(640, 480, 40)) {
    const Eigen::Vector3d ray = unproject(cam, px);
    EXPECT_NEAR(ray.norm(), 1.0, 1e-12);
    EXPECT_LT((project(cam, ray * 2.5) - px).norm(), 1e-8) << px.transpose();
    const Eigen::Vector3d p = backproject(cam, px, 1.7);
    EXPECT_NEAR(p.z(), 1.7, 1e-12);
    EXPECT_LT((project(cam, p) - px).norm(), 1e-8);
  }
}

TEST(Camera, PinholeWithoutDistortionIsLinear) {
  const PinholeCamera cam{640, 480, 500, 500, 320, 240, {}};
  EXPECT_FALSE(cam.has_distortion());
  EXPECT_LT((cam.project({0.1, -0.2, 2.0}) - Eigen::Vector2d(345, 190)).norm(), 1e-12);
  EXPECT_LT((undistort_pixel(cam, {17.0, 33.0}) - Eigen::Vector2d(17.0, 33.0)).norm(), 1e-12);
}

TEST(Camera, PinholeJacobiansMatchNumeric) {
  const PinholeCamera cam = tum_fr1();
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(0.1, 0.2, 1.0), Eigen::Vector3d(-0.5, 0.3, 1.2),
                                   Eigen::Vector3d(0.6, -0.45, 1.0)}) {
    auto f = [&](const Eigen::Vector3d& x) { return cam.project(x); };
    EXPECT_LT((numeric_jacobian<2, 3>(f, p) - cam.project_jacobian(p)).norm(), 1e-5);
    const Eigen::Vector2d xy = p.head<2>() / p.z();
    auto g = [&](const Eigen::Vector2d& x) { return cam.distort(x); };
    EXPECT_LT((numeric_jacobian<2, 2>(g, xy) - cam.distort_jacobian(xy)).norm(), 1e-7);
  }
}

TEST(Camera, PinholeUndistortInvertsDistort) {
  const PinholeCamera cam = tum_fr1();
  for (const auto& px : pixel_grid(640, 480, 32)) {
    const Eigen::Vector2d xy_d((px.x() - cam.cx) / cam.fx, (px.y() - cam.cy) / cam.fy);
    EXPECT_LT((cam.distort(cam.undistort(xy_d)) - xy_d).norm(), 1e-12) << px.transpose();
  }
  // undistort_pixel maps onto the ideal pinhole with the same K.
  const Eigen::Vector2d px(600, 30);
  const Eigen::Vector2d ideal = undistort_pixel(Camera(cam), px);
  const Eigen::Vector3d ray((ideal.x() - cam.cx) / cam.fx, (ideal.y() - cam.cy) / cam.fy, 1.0);
  EXPECT_LT((cam.project(ray) - px).norm(), 1e-8);
}

TEST(Camera, KannalaBrandtRoundTripAndJacobians) {
  const KannalaBrandtCamera cam = fisheye();
  for (const auto& px : pixel_grid(752, 480, 40)) {
    const Eigen::Vector3d ray = cam.unproject(px);
    EXPECT_NEAR(ray.norm(), 1.0, 1e-12);
    EXPECT_LT((cam.project(ray * 3.0) - px).norm(), 1e-8) << px.transpose();
  }
  for (const Eigen::Vector3d& p :
       {Eigen::Vector3d(0.1, 0.2, 1.0), Eigen::Vector3d(-2.0, 0.3, 1.0),
        Eigen::Vector3d(1.0, 1.0, -0.2), Eigen::Vector3d(1e-10, 0, 1), Eigen::Vector3d(0, 0, 2)}) {
    auto f = [&](const Eigen::Vector3d& x) { return cam.project(x); };
    EXPECT_LT((numeric_jacobian<2, 3>(f, p, 1e-7) - cam.project_jacobian(p)).norm(), 1e-4)
        << p.transpose();
  }
  // Beyond 90 degrees off-axis the fisheye still projects and unprojects.
  const Eigen::Vector3d behind_side = Eigen::Vector3d(1.0, 0.2, -0.3).normalized();
  EXPECT_LT((cam.unproject(cam.project(behind_side)) - behind_side).norm(), 1e-9);
}

TEST(Camera, VariantDispatch) {
  const Camera a = tum_fr1();
  const Camera b = fisheye();
  EXPECT_EQ(model_name(a), "PinHole");
  EXPECT_EQ(model_name(b), "KannalaBrandt8");
  EXPECT_EQ(image_width(b), 752);
  EXPECT_TRUE(in_image(a, {0, 0}));
  EXPECT_FALSE(in_image(a, {640, 0}));
  EXPECT_FALSE(in_image(a, {5, 5}, 10.0));
  EXPECT_DOUBLE_EQ(intrinsic_matrix(a)(0, 2), 318.643040);
}

}  // namespace
}  // namespace coloc
