#pragma once
// Bundle adjustment over keyframe poses and points with Ceres (sparse Schur, Huber kernel),
// ORB-SLAM's local BA: optimize, drop observations whose chi2 exceeds 7.815 (stereo-like) /
// 5.991 (monocular), optimize again without the kernel. Fixed poses (keyframes outside the
// window that see window points) constrain the gauge. The problem is a value: the caller
// copies the window out of the map, runs this without holding the map lock, and writes back.
//
// Pose parameter blocks are [tx ty tz qx qy qz qw] of cam_from_world with the manifold
// x <- exp(delta) * x (delta = (rho, phi)); cost functions give d r / d delta analytically in the
// first six ambient columns (the "lifted" Jacobian, PlusJacobian = [I; 0]).
#include <ceres/cost_function.h>
#include <ceres/manifold.h>
#include <ceres/sized_cost_function.h>

#include <atomic>
#include <cstdint>
#include <vector>

#include "slam/core/se3.hpp"
#include "slam/optim/reprojection.hpp"

namespace coloc::slam::optim {

struct BundleProblem {
  struct Pose {
    SE3 cam_from_world;
    bool fixed = false;
  };
  struct Observation {
    std::uint32_t pose = 0;   // index into poses
    std::uint32_t point = 0;  // index into points
    Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
    double u_right = -1.0;  // < 0: monocular
    double inv_sigma2 = 1.0;
    // Rolling shutter (optim::shutter_shifted): how the observation moves with the readout
    // time; zero when its keyframe's angular rate is unknown.
    Eigen::Vector3d shear = Eigen::Vector3d::Zero();
  };
  // The rolling-shutter readout time as one more unknown, shared by every observation with a
  // shear. The pixels are compensated with `current`; a prior (`prior`, `prior_sigma`) keeps
  // one small window from moving it far: many windows in turn carry it where the data ask.
  struct Readout {
    bool estimate = false;
    double current = 0.0;        // seconds
    double prior = 0.0;          // seconds
    double prior_sigma = 0.002;  // seconds
    double min = 0.0, max = 0.05;
  };
  // An accelerometer on a keyframe (mapping/gravity.hpp): the mean specific force it measured
  // over a short window, in the camera frame, and the camera's mean acceleration over the same
  // window in the world frame. Each ties its pose's tilt to one gravity direction shared by all,
  // estimated with a constant accelerometer bias (optim::GravityCost). Vision alone leaves the
  // tilt to a random walk: on the twin building most of the error after loop closing is height.
  struct Gravity {
    std::uint32_t pose = 0;  // index into poses
    // Index of its accelerometer bias: one per recording (a sensor's bias changes from one
    // power-up to the next), the first 0.
    std::uint32_t bias = 0;
    Eigen::Vector3d specific_force_cam = Eigen::Vector3d::Zero();  // m/s^2
    Eigen::Vector3d accel_world = Eigen::Vector3d::Zero();         // m/s^2
  };
  struct GravityModel {
    double magnitude = 9.81;        // m/s^2
    double sigma = 0.02;            // m/s^2 per axis, of one keyframe's Gravity
    double accel_bias_sigma = 0.1;  // m/s^2 per axis: a prior for sequences that turn little
  };
  // A gyro between two keyframes (mapping/gyro.hpp): the rotation cam_a_from_cam_b it
  // integrated at zero bias, and how that changes with the bias (camera frame, rad/s), to first
  // order: measured(b) = measured * exp(bias_jacobian * b). Each keyframe with a Gyro has a bias
  // of its own; consecutive ones are tied by the bias random walk (optim::GyroCost), and the
  // first of each chain (a recording) by a prior.
  struct Gyro {
    std::uint32_t pose_a = 0, pose_b = 0;  // indices into poses; a earlier than b
    SO3 cam_a_from_cam_b;
    Eigen::Matrix3d bias_jacobian = Eigen::Matrix3d::Zero();
    double dt = 0.0;  // seconds integrated
  };
  struct GyroModel {
    double noise_density = 1.7e-4;  // rad/s/sqrt(Hz) (ORB-SLAM3's IMU.NoiseGyro)
    double random_walk = 1.9e-5;    // rad/s^2/sqrt(Hz) (IMU.GyroWalk)
    double bias_sigma = 0.05;       // rad/s per axis: a prior on each chain's first bias
  };
  std::vector<Pose> poses;
  std::vector<Eigen::Vector3d> points;  // world, metres
  std::vector<Observation> observations;
  Readout readout;
  std::vector<Gravity> gravity;
  GravityModel gravity_model;
  std::vector<Gyro> gyro;
  GyroModel gyro_model;
};

struct BundleOptions {
  int iterations_robust = 5;   // first pass, Huber kernel
  int iterations_refine = 10;  // second pass, outliers removed, no kernel
  double chi2_stereo = 7.815;
  double chi2_mono = 5.991;
  // A gravity window or gyro pair whose whitened residual exceeds this (3 dof, 99.9 %) after
  // the first pass is dropped from the second, as observations are: the second pass has no
  // kernel, and one pair the frames and the gyro disagree on (a knock, a time glitch, a head
  // that snapped between two frames) would otherwise bend the map by its full weight.
  double chi2_inertial = 16.27;
  // Problems with at most this many free poses solve the reduced camera system densely (Ceres
  // DENSE_SCHUR), larger ones sparsely. A local BA window's system is small and nearly full
  // (its keyframes are covisible by construction), where the sparse factorization's ordering
  // and bookkeeping cost more than they save: 7-Scenes, sequential, 107 keyframes, local BA
  // median 136-139 -> 115-117 ms per keyframe over two runs each, the same ATE to the micrometre.
  int dense_schur_max_poses = 60;
  // Those problems, when made of reprojections only, go to our own Levenberg-Marquardt
  // (dense_schur_lm.hpp) rather than Ceres' DENSE_SCHUR: the same cost and stopping rules at
  // a fraction of the time. Off, Ceres solves every problem (tests compare the two).
  bool own_dense_solver = true;
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

// Where a bundle adjustment's time went, from Ceres' summaries (milliseconds, summed over the
// passes): building the problems, Ceres' preprocessing, evaluating residuals and Jacobians,
// and the linear solver (Schur elimination and factorization).
struct BundleTiming {
  double build_ms = 0.0, preprocess_ms = 0.0, evaluate_ms = 0.0, linear_solver_ms = 0.0;
  double total_ms = 0.0;
};

struct BundleResult {
  std::vector<std::uint8_t> outlier;  // per observation, after the first pass
  bool aborted = false;               // the abort flag was raised (results still usable)
  int iterations = 0;
  double initial_cost = 0.0, final_cost = 0.0;
  BundleTiming timing;
  double readout_change = 0.0;  // seconds, estimated readout - problem.readout.current
  // With BundleProblem::gravity: the unit vector against gravity in the world frame (zero
  // without), and the accelerometer biases by Gravity::bias (camera frame, m/s^2).
  Eigen::Vector3d up_world = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> accel_bias;
  // With BundleProblem::gyro: the gyro bias (camera frame, rad/s) per pose, zero for poses
  // without a Gyro; empty without.
  std::vector<Eigen::Vector3d> gyro_bias;
  // Per BundleProblem::gravity / gyro entry: dropped after the first pass (chi2_inertial).
  std::vector<std::uint8_t> gravity_outlier, gyro_outlier;
  // RMS length of the kept gravity residuals (m/s^2) and gyro residuals (rad) at the result.
  double gravity_rms = 0.0, gyro_rms = 0.0;
};

// Optimizes `problem` in place. `abort` (may be null) is polled between iterations.
BundleResult bundle_adjust(BundleProblem& problem, const Intrinsics& intrinsics,
                           const BundleOptions& options = {},
                           const std::atomic<bool>* abort = nullptr);

// The pose manifold described above (exposed for tests).
class PoseManifold : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 7; }
  int TangentSize() const override { return 6; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  bool PlusJacobian(const double* x, double* jacobian) const override;
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  bool MinusJacobian(const double* x, double* jacobian) const override;
};

// Whitened reprojection residuals with analytic (lifted) Jacobians w.r.t. pose and point.
class StereoReprojectionCost : public ceres::SizedCostFunction<3, 7, 3> {
 public:
  StereoReprojectionCost(const Intrinsics& k, const Eigen::Vector3d& obs, double inv_sigma)
      : k_(k), obs_(obs), inv_sigma_(inv_sigma) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Intrinsics k_;
  Eigen::Vector3d obs_;
  double inv_sigma_;
};

class MonoReprojectionCost : public ceres::SizedCostFunction<2, 7, 3> {
 public:
  MonoReprojectionCost(const Intrinsics& k, const Eigen::Vector2d& obs, double inv_sigma)
      : k_(k), obs_(obs), inv_sigma_(inv_sigma) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Intrinsics k_;
  Eigen::Vector2d obs_;
  double inv_sigma_;
};

// The same with the readout change (seconds) as a third parameter (Observation::shear).
template <int kRows>
class ShutterReprojectionCost : public ceres::SizedCostFunction<kRows, 7, 3, 1> {
 public:
  ShutterReprojectionCost(const Intrinsics& k, const Eigen::Vector3d& obs,
                          const Eigen::Vector3d& shear, double inv_sigma)
      : k_(k), obs_(obs), shear_(shear), inv_sigma_(inv_sigma) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Intrinsics k_;
  Eigen::Vector3d obs_;  // (u, v, u_r); u_r unused with kRows = 2
  Eigen::Vector3d shear_;
  double inv_sigma_;
};

// Pose <-> 7-vector [t, q(xyzw)].
void pose_to_array(const SE3& pose, double* x);
SE3 pose_from_array(const double* x);

}  // namespace coloc::slam::optim
