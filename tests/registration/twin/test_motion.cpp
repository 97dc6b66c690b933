#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <numeric>

#include "registration/twin/motion.hpp"
#include "registration/twin/sensor_noise.hpp"
#include "slam/core/error.hpp"

namespace coloc::registration::twin {
namespace {

std::vector<Eigen::Vector2d> square_path() {
  return {{0, 0}, {3, 0}, {3, 2}, {0, 2}, {0, 0.5}};
}

TEST(TwinMotion, WalkIsSmoothAndFollowsThePath) {
  const WalkTrajectory walk(square_path(), WalkOptions{}, 1);
  EXPECT_GT(walk.end_time() - walk.start_time(), 8.0);
  double max_step = 0.0;
  for (double t = walk.start_time(); t < walk.end_time(); t += 1.0 / 30) {
    const SE3 a = walk.world_from_cam(t), b = walk.world_from_cam(t + 1.0 / 30);
    max_step = std::max(max_step, translation_distance(a, b));
    EXPECT_NEAR(a.translation().z(), 1.6, 0.02);
    // Camera y (image down) points roughly down in the world.
    EXPECT_LT(a.rotation().col(1).z(), -0.8);
  }
  EXPECT_LT(max_step, 1.5 / 30);  // never faster than 1.5 m/s
  EXPECT_NEAR(walk.world_from_cam(walk.start_time()).translation().x(), 0.0, 1e-9);
}

// A walk that sets off in any direction turns its head smoothly from the first frame: the
// rendered frames and the IMU must agree (a room walk once snapped 174 mrad in one frame at
// 0.3 s, where the walker's heading switched from a default to the path's).
TEST(TwinMotion, WalkSettingOffInAnyDirectionTurnsSmoothly) {
  for (const double angle : {0.0, 1.0, 2.5, -2.0}) {
    const Eigen::Rotation2Dd turn(angle);
    std::vector<Eigen::Vector2d> path;
    for (const Eigen::Vector2d& p : square_path())
      path.push_back(turn * p);
    const WalkTrajectory walk(path, WalkOptions{}, 3);
    double max_turn = 0.0;
    for (double t = walk.start_time(); t < walk.start_time() + 3.0; t += 1.0 / 30) {
      max_turn = std::max(max_turn, angular_distance(walk.world_from_cam(t).so3(),
                                                     walk.world_from_cam(t + 1.0 / 30).so3()));
    }
    EXPECT_LT(max_turn, 0.05) << "path turned by " << angle << " rad";  // 1.5 rad/s
  }
}

TEST(TwinMotion, ImuIntegratesBackToTheTrajectory) {
  const WalkTrajectory walk(square_path(), WalkOptions{}, 4);
  ImuOptions o;
  std::vector<ImuSample> meas;
  std::vector<ImuTruth> truth;
  simulate_imu(walk, o, 9, meas, truth);
  ASSERT_EQ(meas.size(), truth.size());
  ASSERT_GT(truth.size(), 1000u);
  EXPECT_NEAR(truth[1].ideal.timestamp - truth[0].ideal.timestamp, 1.0 / o.rate, 1e-9);
  const SE3 cam_from_imu = o.imu_from_cam.inverse();
  const auto pose = [&](double t) { return walk.world_from_cam(t) * cam_from_imu; };
  // Integrate the ideal measurements over 1 s starting mid-walk.
  const std::size_t k0 = 600, n = 200;
  const double dt = 1.0 / o.rate;
  const double t0 = truth[k0].ideal.timestamp;
  Eigen::Matrix3d r = pose(t0).rotation();
  Eigen::Vector3d p = pose(t0).translation();
  Eigen::Vector3d v = (pose(t0 + 1e-4).translation() - pose(t0 - 1e-4).translation()) / 2e-4;
  const Eigen::Vector3d g(0, 0, -o.gravity);
  for (std::size_t k = k0; k < k0 + n; ++k) {
    const ImuSample& a = truth[k].ideal;
    const ImuSample& b = truth[k + 1].ideal;
    const Eigen::Vector3d acc_a = r * a.accel + g;
    const Eigen::Matrix3d r_next = r * SO3::exp(0.5 * (a.gyro + b.gyro) * dt).matrix();
    const Eigen::Vector3d acc_b = r_next * b.accel + g;
    const Eigen::Vector3d v_next = v + 0.5 * (acc_a + acc_b) * dt;
    p += 0.5 * (v + v_next) * dt;
    v = v_next;
    r = r_next;
  }
  const SE3 end = pose(truth[k0 + n].ideal.timestamp);
  EXPECT_LT((p - end.translation()).norm(), 0.005);
  EXPECT_LT(angular_distance(SO3::from_matrix(r), end.so3()), 1e-3);
  // Measurements = ideal + bias + noise: the residual's spread matches the noise density.
  double sum2 = 0.0;
  for (std::size_t k = 0; k < meas.size(); ++k) {
    sum2 += (meas[k].gyro - truth[k].ideal.gyro - truth[k].gyro_bias).squaredNorm();
  }
  const double sigma = std::sqrt(sum2 / (3.0 * meas.size()));
  EXPECT_NEAR(sigma, o.gyro_noise_density * std::sqrt(o.rate), 0.1 * sigma);
}

TEST(TwinMotion, HeadsetDriftsButComposesToTheTruth) {
  const WalkTrajectory walk(square_path(), WalkOptions{}, 2);
  HeadsetOptions o;
  const HeadsetStreams h = simulate_headset(walk, o, 3);
  ASSERT_EQ(h.xr_from_headset.size(), h.world_from_headset.size());
  EXPECT_NEAR(h.xr_from_headset[1].timestamp - h.xr_from_headset[0].timestamp, 1.0 / 90, 1e-9);
  for (std::size_t i = 0; i < h.xr_from_headset.size(); i += 17) {
    const SE3 composed = h.world_from_xr[i].world_from_cam * h.xr_from_headset[i].world_from_cam;
    EXPECT_LT(translation_distance(composed, h.world_from_headset[i].world_from_cam), 6 * o.jitter);
    const SE3 truth = walk.world_from_cam(h.world_from_headset[i].timestamp) * o.cam_from_headset;
    EXPECT_LT(translation_distance(truth, h.world_from_headset[i].world_from_cam), 1e-12);
  }
  // The xr origin drifts away from where it started.
  EXPECT_GT(translation_distance(h.world_from_xr.front().world_from_cam,
                                 h.world_from_xr.back().world_from_cam),
            1e-4);
}

TEST(TwinSensorNoise, DepthNoiseGrowsWithTheSquareOfDepth) {
  DepthNoiseOptions o;
  o.random_dropout = 0.0;
  const double f = 386.0;
  for (double z : {1.0, 2.0, 4.0}) {
    const cv::Mat depth(240, 320, CV_32F, cv::Scalar(z));
    const cv::Mat mm = apply_depth_noise(depth, f, o, 11);
    ASSERT_EQ(mm.type(), CV_16U);
    std::vector<double> err;
    for (int v = 0; v < mm.rows; ++v) {
      for (int u = 0; u < mm.cols; ++u) {
        const auto d = mm.at<std::uint16_t>(v, u);
        if (d > 0) err.push_back(d / 1000.0 - z);
      }
    }
    ASSERT_GT(err.size(), mm.total() * 9 / 10);
    const double mean = std::accumulate(err.begin(), err.end(), 0.0) / err.size();
    double var = 0.0;
    for (double e : err)
      var += (e - mean) * (e - mean);
    const double sigma = std::sqrt(var / err.size());
    const double expected = z * z * o.disparity_sigma / (f * o.baseline);
    EXPECT_NEAR(mean, 0.0, std::max(0.001, 0.3 * expected)) << z;
    EXPECT_NEAR(sigma, std::hypot(expected, 0.0003), 0.25 * expected + 0.0005) << z;
  }
}

TEST(TwinSensorNoise, RangeLimitsEdgesAndOcclusionShadow) {
  DepthNoiseOptions o;
  o.random_dropout = 0.0;
  o.blob_dropout = 0.0;
  const double f = 386.0;
  // Far left half (3 m), near right half (1 m): the shadow lies left of the near object.
  cv::Mat depth(100, 320, CV_32F, cv::Scalar(3.0));
  depth.colRange(160, 320).setTo(1.0);
  const cv::Mat mm = apply_depth_noise(depth, f, o, 5);
  const int band = static_cast<int>(std::lround(f * o.baseline * (1.0 / 1.0 - 1.0 / 3.0)));
  for (int v = 0; v < 100; ++v) {
    for (int u = 160 - band; u < 160; ++u)
      EXPECT_EQ(mm.at<std::uint16_t>(v, u), 0) << u;
    EXPECT_GT(mm.at<std::uint16_t>(v, 160 - band - 10), 0);
    EXPECT_GT(mm.at<std::uint16_t>(v, 200), 0);
  }
  const cv::Mat far = apply_depth_noise(cv::Mat(10, 10, CV_32F, cv::Scalar(7.0)), f, o, 1);
  EXPECT_EQ(cv::countNonZero(far), 0);
  const cv::Mat near = apply_depth_noise(cv::Mat(10, 10, CV_32F, cv::Scalar(0.2)), f, o, 1);
  EXPECT_EQ(cv::countNonZero(near), 0);
  // Blob dropouts remove the requested fraction of a flat view.
  DepthNoiseOptions blobs;
  blobs.random_dropout = 0.0;
  const cv::Mat flat = apply_depth_noise(cv::Mat(240, 320, CV_32F, cv::Scalar(2.0)), f, blobs, 3);
  EXPECT_NEAR(1.0 - cv::countNonZero(flat) / 76800.0, blobs.blob_dropout, 0.003);
  DepthNoiseOptions bad;
  bad.max_range = -1;
  EXPECT_THROW(apply_depth_noise(depth, f, bad, 1), Error);
}

}  // namespace
}  // namespace coloc::registration::twin
