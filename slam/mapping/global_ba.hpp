#pragma once
// Global bundle adjustment: every keyframe pose (except the first, which fixes the world frame)
// and every map point, with the local BA's two passes (Huber, then without the outliers). Run
// it on a finished map, after local mapping has stopped: the map an offline session saves (and
// registers to the laser scan) is then consistent as a whole, not only window by window.
// Frames follow through their reference keyframes (System::trajectory()).
#include "slam/map/shared_map.hpp"
#include "slam/mapping/inertial.hpp"
#include "slam/optim/bundle_adjustment.hpp"

namespace coloc::slam::mapping {

struct GlobalBaOptions {
  optim::BundleOptions ba{.iterations_robust = 10, .iterations_refine = 20};
  // Throws coloc::Error naming the first invalid field.
  void check() const { ba.check(); }
};

struct GlobalBaReport {
  std::size_t keyframes = 0, points = 0, observations = 0;
  std::size_t outliers = 0;  // observations removed from the map
  int iterations = 0;
  // RMS length of the reprojection residual (pixels; (u, v, u_r) for stereo-like observations)
  // over the observations kept, before and after.
  double initial_rms_px = 0.0, final_rms_px = 0.0;
  double ms = 0.0;
  // With gravity: keyframes that had a measurement (of which gravity_outliers were dropped
  // after the first pass: optim::BundleOptions::chi2_inertial), the accelerometer bias
  // estimated for the newest recording that stored any (camera frame, m/s^2) and the RMS of
  // the kept gravity residuals after (m/s^2).
  std::size_t gravity_keyframes = 0, gravity_outliers = 0;
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();
  double gravity_rms = 0.0;
  // With the gyro: pairs of consecutive keyframes tied (gyro_outliers of them dropped), the RMS
  // angle between the gyro's rotation (bias applied) and the map's after over the kept pairs
  // (rad), and their mean gyro bias (camera frame, rad/s).
  std::size_t gyro_pairs = 0, gyro_outliers = 0;
  double gyro_rms = 0.0;
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();
};

// Takes the map lock to copy the problem out and to write the result back, not while solving.
// `imu`: what this recording's log measured, first stored in the map (record_inertial); the
// inertial terms are then what every keyframe stores, this recording's and earlier ones'.
GlobalBaReport global_bundle_adjustment(map::SharedMap& shared, const GlobalBaOptions& options = {},
                                        const InertialMeasurements& imu = {});

}  // namespace coloc::slam::mapping
