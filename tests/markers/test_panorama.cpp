// Panorama models and cube-face resampling: the mapping must be geometrically exact.

#include <gtest/gtest.h>

#include <random>

#include "markers/panorama.hpp"
#include "slam/core/error.hpp"

namespace coloc::markers {
namespace {

Eigen::Vector3d random_direction(std::mt19937& rng) {
  std::normal_distribution<double> n;
  return Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
}

TEST(Panorama, PixelAndDirectionAreInverse) {
  PanoramaModel cylindrical;
  cylindrical.kind = PanoramaKind::kCylindrical;
  cylindrical.width = 3000;
  cylindrical.height = 1000;
  cylindrical.pixel_width = 2 * M_PI / 3000;
  cylindrical.pixel_height = 0.002;
  cylindrical.radius = 1.0;
  cylindrical.principal_point_y = 480.0;
  std::mt19937 rng(3);
  for (const PanoramaModel& m : {PanoramaModel::equirectangular(4096), cylindrical}) {
    for (int i = 0; i < 1000; ++i) {
      Eigen::Vector3d d = random_direction(rng);
      if (m.kind == PanoramaKind::kCylindrical) d.z() *= 0.3;  // within the cylinder's height
      d.normalize();
      const Eigen::Vector2d p = m.pixel(d);
      EXPECT_GE(p.x(), -0.5);
      EXPECT_LT(p.x(), m.width - 0.5);
      EXPECT_LT((m.direction(p) - d).norm(), 1e-12);
    }
  }
  // The stated convention: +x at the middle column, +y (azimuth +90 deg) left of it, up at the top.
  const PanoramaModel e = PanoramaModel::equirectangular(4096);
  EXPECT_LT((e.pixel({1, 0, 0}) - Eigen::Vector2d(2047.5, 1023.5)).norm(), 1e-9);
  EXPECT_LT((e.pixel({0, 1, 0}) - Eigen::Vector2d(1023.5, 1023.5)).norm(), 1e-9);
  EXPECT_NEAR(e.pixel({0, 1e-9, 1}).y(), -0.5, 1e-6);
}

TEST(Panorama, CubeFacesLookWhereTheySay) {
  const auto r = cube_face_rotations();
  const std::array<Eigen::Vector3d, 6> forward{Eigen::Vector3d::UnitX(), -Eigen::Vector3d::UnitX(),
                                               Eigen::Vector3d::UnitY(), -Eigen::Vector3d::UnitY(),
                                               Eigen::Vector3d::UnitZ(), -Eigen::Vector3d::UnitZ()};
  for (int f = 0; f < kCubeFaces; ++f) {
    EXPECT_LT((r[f] * Eigen::Vector3d::UnitZ() - forward[f]).norm(), 1e-12) << cube_face_name(f);
    EXPECT_NEAR(r[f].matrix().determinant(), 1.0, 1e-12);
  }
  // Side faces: image down is world down.
  EXPECT_LT((r[0] * Eigen::Vector3d::UnitY() + Eigen::Vector3d::UnitZ()).norm(), 1e-12);
}

// A smooth test pattern defined on directions: a face resampled from the panorama must show, at
// every pixel, the pattern's value in that pixel's direction (up to bilinear interpolation), and
// a narrow blob at a known direction must appear where the face camera projects that direction.
TEST(Panorama, CubeFaceResamplingIsGeometricallyExact) {
  const PanoramaModel model = PanoramaModel::equirectangular(2048);
  const Eigen::Vector3d blob = Eigen::Vector3d(0.8, 0.35, 0.3).normalized();  // in face +x
  const double sigma = 4.0 * model.pixel_width;
  const auto pattern = [&](const Eigen::Vector3d& d) {
    const double a = std::acos(std::clamp(d.normalized().dot(blob), -1.0, 1.0));
    return 40.0 + 60.0 * (1.0 + std::sin(3.0 * d.x()) * std::cos(2.0 * d.z())) +
           100.0 * std::exp(-0.5 * a * a / (sigma * sigma));
  };
  const auto blob_only = [&](const Eigen::Vector3d& d) {
    const double a = std::acos(std::clamp(d.normalized().dot(blob), -1.0, 1.0));
    return 100.0 * std::exp(-0.5 * a * a / (sigma * sigma));
  };
  cv::Mat pano(model.height, model.width, CV_32FC1), blob_pano(model.height, model.width, CV_32FC1);
  for (int r = 0; r < model.height; ++r) {
    for (int c = 0; c < model.width; ++c) {
      const Eigen::Vector3d d = model.direction({c, r});
      pano.at<float>(r, c) = static_cast<float>(pattern(d));
      blob_pano.at<float>(r, c) = static_cast<float>(blob_only(d));
    }
  }
  cv::Mat pano8;
  pano.convertTo(pano8, CV_8U);
  const int size = 512;
  const PinholeCamera camera = cube_face_camera(size);
  const auto rotations = cube_face_rotations();
  for (int f = 0; f < kCubeFaces; ++f) {
    const cv::Mat face = resample_cube_face(pano8, model, f, size);
    double worst = 0.0;
    for (int v = 0; v < size; v += 7) {
      for (int u = 0; u < size; u += 7) {
        const Eigen::Vector3d d = rotations[f] * camera.unproject({u, v});
        worst = std::max(worst, std::abs(face.at<unsigned char>(v, u) - pattern(d)));
      }
    }
    EXPECT_LT(worst, 3.0) << "face " << cube_face_name(f);  // 8-bit rounding + interpolation
  }
  // The blob's peak, by a parabola fit around the brightest pixel of face +x.
  cv::Mat face = resample_cube_face(blob_pano, model, 0, size);
  const Eigen::Vector2d expected = camera.project(rotations[0].inverse() * blob);
  cv::Point peak;
  cv::Mat roi = face(
      cv::Rect(static_cast<int>(expected.x()) - 10, static_cast<int>(expected.y()) - 10, 21, 21));
  cv::minMaxLoc(roi, nullptr, nullptr, nullptr, &peak);
  const int px = peak.x + static_cast<int>(expected.x()) - 10;
  const int py = peak.y + static_cast<int>(expected.y()) - 10;
  const auto vertex = [](double a, double b, double c) { return 0.5 * (a - c) / (a - 2 * b + c); };
  const double sx =
      px + vertex(face.at<float>(py, px - 1), face.at<float>(py, px), face.at<float>(py, px + 1));
  const double sy =
      py + vertex(face.at<float>(py - 1, px), face.at<float>(py, px), face.at<float>(py + 1, px));
  EXPECT_NEAR(sx, expected.x(), 0.15);
  EXPECT_NEAR(sy, expected.y(), 0.15);
}

TEST(Panorama, BadInputs) {
  PanoramaModel m = PanoramaModel::equirectangular(256);
  EXPECT_THROW(resample_cube_face(cv::Mat(10, 10, CV_8UC1), m, 0, 64), Error);
  m.pixel_width = 0;
  EXPECT_THROW(m.check(), Error);
}

}  // namespace
}  // namespace coloc::markers
