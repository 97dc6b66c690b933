// Rolling-shutter compensation: keypoints observed by a turning rolling-shutter camera (each row
// at its own time) are moved to where a global-shutter camera at the middle row's time sees them.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "slam/core/so3.hpp"
#include "slam/frame/frame.hpp"
#include "slam/frame/rolling_shutter.hpp"
#include "tests/slam/support/slam_test_support.hpp"

namespace coloc::slam::frame {
namespace {

constexpr double kF = 500.0, kCx = 320.0, kCy = 240.0;
constexpr int kRows = 480;

Eigen::Vector2d project(const Eigen::Vector3d& p) {
  return {kF * p.x() / p.z() + kCx, kF * p.y() / p.z() + kCy};
}

// The pixel where a rolling-shutter camera sees `p` (camera frame at the middle row's time):
// the row v is read at tau(v), when the camera has turned by exp(omega * tau); fixed point in v.
Eigen::Vector2d rolling_shutter_pixel(const Eigen::Vector3d& p, const Eigen::Vector3d& omega,
                                      double readout) {
  Eigen::Vector2d uv = project(p);
  for (int it = 0; it < 20; ++it) {
    const double tau = (uv.y() - 0.5 * (kRows - 1)) / kRows * readout;
    uv = project(SO3::exp(omega * tau).inverse() * p);
  }
  return uv;
}

TEST(RollingShutter, KeypointsMoveToTheMiddleRowTime) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  const Eigen::Vector3d omega(0.4, 2.5, -0.6);  // rad/s: a fast turn, as in TUM fr1/rpy
  const double readout = 0.02;
  features::OrbFeatures f;
  std::vector<Eigen::Vector2d> truth;
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d p(1.2 * uni(rng), 0.9 * uni(rng), 2.0 + uni(rng));
    const Eigen::Vector2d rs = rolling_shutter_pixel(p, omega, readout);
    if (rs.x() < 0 || rs.y() < 0 || rs.x() >= 640 || rs.y() >= kRows) continue;
    features::Keypoint kp;
    kp.x = kp.ux = static_cast<float>(rs.x());
    kp.y = kp.uy = static_cast<float>(rs.y());
    f.keypoints.push_back(kp);
    truth.push_back(project(p));
  }
  double before = 0.0, after = 0.0;
  features::OrbFeatures compensated = f;
  compensate_rolling_shutter(compensated, {readout, kRows}, omega, kF, kF, kCx, kCy);
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const auto& a = f.keypoints[i];
    const auto& b = compensated.keypoints[i];
    before = std::max(before, (Eigen::Vector2d(a.ux, a.uy) - truth[i]).norm());
    after = std::max(after, (Eigen::Vector2d(b.ux, b.uy) - truth[i]).norm());
    EXPECT_EQ(a.x, b.x);  // the detected pixel (depth lookup) stays
  }
  std::cout << "max keypoint error " << before << " px -> " << after << " px\n";
  EXPECT_GT(before, 5.0);
  EXPECT_LT(after, 0.01);

  // Global shutter (readout 0) or no rotation: nothing moves.
  features::OrbFeatures same = f;
  compensate_rolling_shutter(same, {0.0, kRows}, omega, kF, kF, kCx, kCy);
  compensate_rolling_shutter(same, {readout, kRows}, Eigen::Vector3d::Zero(), kF, kF, kCx, kCy);
  for (std::size_t i = 0; i < f.size(); ++i)
    EXPECT_FLOAT_EQ(same.keypoints[i].ux, f.keypoints[i].ux);
}

// The rate is observable in one image: rows read later are rotated further. From a prior 1 rad/s
// off, the estimate lands on the true rate (within 0.05 rad/s with 0.3 px pixel noise).
TEST(RollingShutter, RotationRateFromTheRowShear) {
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.3);
  const Eigen::Vector3d omega(0.3, -2.0, 0.4);
  const RollingShutter shutter{0.02, kRows};
  std::vector<RateObservation> obs;
  while (obs.size() < 300) {
    const Eigen::Vector3d p(1.2 * uni(rng), 0.9 * uni(rng), 2.0 + uni(rng));
    const Eigen::Vector2d rs = rolling_shutter_pixel(p, omega, shutter.readout);
    if (rs.x() < 0 || rs.y() < 0 || rs.x() >= 640 || rs.y() >= kRows) continue;
    const Eigen::Vector2d seen = rs + Eigen::Vector2d(noise(rng), noise(rng));
    obs.push_back({p, seen, row_time(seen.y(), shutter), 1.0});
  }
  const Eigen::Vector3d prior = omega + Eigen::Vector3d(0.6, 0.6, -0.6);
  const Eigen::Vector3d estimate = estimate_rotation_rate(obs, prior, 1.0, kF, kF, kCx, kCy);
  std::cout << "rate error " << (prior - omega).norm() << " -> " << (estimate - omega).norm()
            << " rad/s\n";
  EXPECT_LT((estimate - omega).norm(), 0.05);
  // Too few observations: the prior comes back unchanged.
  obs.resize(10);
  EXPECT_EQ(estimate_rotation_rate(obs, prior, 1.0, kF, kF, kCx, kCy), prior);
}

// `n` undistorted keypoints on a diagonal from `first`, `step` pixels apart, over the rows.
features::OrbFeatures diagonal_keypoints(int n, Eigen::Vector2f first, Eigen::Vector2f step) {
  features::OrbFeatures f;
  for (int i = 0; i < n; ++i) {
    features::Keypoint kp;
    kp.x = kp.ux = first.x() + step.x() * static_cast<float>(i);
    kp.y = kp.uy = first.y() + step.y() * static_cast<float>(i);
    f.keypoints.push_back(kp);
    f.descriptors.push_back({});
  }
  return f;
}

TEST(RollingShutter, FrameKeepsVirtualRightCoordinatesAndGridConsistent) {
  auto g = std::make_shared<FrameGeometry>(*test_support::test_geometry());
  g->readout = 0.02;
  const features::OrbFeatures f = diagonal_keypoints(50, {100.0f, 40.0f}, {8.0f, 8.0f});
  Frame frame(FrameId(1), 0.0, f, cv::Mat(480, 640, CV_32FC1, cv::Scalar(2.0f)), g);
  frame.compensate_rolling_shutter(Eigen::Vector3d(0.0, 3.0, 0.0), 480, 0.02);
  for (std::size_t i = 0; i < frame.size(); ++i) {
    const auto& kp = frame.features.keypoints[i];
    EXPECT_NEAR(frame.u_right[i], kp.ux - g->bf / 2.0, 1e-3);
    const auto near = frame.features_in_area(kp.ux, kp.uy, 0.5);
    EXPECT_NE(std::find(near.begin(), near.end(), i), near.end()) << "keypoint " << i;
  }
  // A turn about y moves points sideways, more the further they are from the middle row.
  EXPECT_GT(std::abs(frame.features.keypoints[0].ux - f.keypoints[0].ux), 1.0);
}

TEST(RollingShutter, FrameTakesAnotherRateAsIfCompensatedWithItAlone) {
  auto g = std::make_shared<FrameGeometry>(*test_support::test_geometry());
  const features::OrbFeatures f = diagonal_keypoints(40, {60.0f, 10.0f}, {13.0f, 11.5f});
  const cv::Mat depth(480, 640, CV_32FC1, cv::Scalar(2.0f));
  const Eigen::Vector3d refined(0.4, 2.5, -0.3), from_poses(-0.2, 1.8, 0.5);
  Frame swapped(FrameId(1), 0.0, f, depth, g), direct(FrameId(2), 0.0, f, depth, g);
  swapped.compensate_rolling_shutter(refined, 480, 0.02);
  swapped.set_shutter_rate(from_poses);
  direct.compensate_rolling_shutter(from_poses, 480, 0.02);
  EXPECT_EQ(swapped.shutter_rate, from_poses);
  EXPECT_EQ(swapped.shutter_readout, 0.02);
  double moved = 0.0;
  for (std::size_t i = 0; i < swapped.size(); ++i) {
    const auto& a = swapped.features.keypoints[i];
    const auto& b = direct.features.keypoints[i];
    EXPECT_NEAR(a.ux, b.ux, 1e-3) << i;
    EXPECT_NEAR(a.uy, b.uy, 1e-3) << i;
    EXPECT_NEAR(swapped.u_right[i], a.ux - g->bf / 2.0, 1e-3);
    moved = std::max(moved, double{std::abs(a.ux - f.keypoints[i].ux)});
  }
  EXPECT_GT(moved, 3.0);  // the comparison is not between two uncompensated frames
}

}  // namespace
}  // namespace coloc::slam::frame
