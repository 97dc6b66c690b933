#include "registration/handeye/opencv/compare.hpp"

#include <Eigen/Cholesky>
#include <array>
#include <numbers>
#include <opencv2/core/eigen.hpp>
#include <random>

#include "registration/handeye/refine.hpp"
#include "slam/core/error.hpp"

namespace coloc::registration::handeye {

namespace {

cv::Mat to_cv(const Eigen::Matrix3d& m) {
  cv::Mat out;
  cv::eigen2cv(m, out);
  return out;
}

cv::Mat to_cv(const Eigen::Vector3d& v) {
  cv::Mat out;
  cv::eigen2cv(v, out);
  return out;
}

// Adds kBoundDraws error norms of X drawn from N(0, Cramer-Rao bound) for this session, so that
// the bound's median and p90 read like those of an efficient unbiased estimator.
void add_bound_draws(const Simulation& sim, const SimulationOptions& o, MethodErrors& out) {
  constexpr int kBoundDraws = 32;
  const std::vector<bool> used(sim.registrations.size(), true);
  const std::optional<Matrix6d> bound = cramer_rao_bound(
      sim.registrations, used, sim.device_from_marker, sim.vr_from_camera, 1.0, noise_model(o));
  if (!bound) return;
  const Eigen::LLT<Matrix6d> llt(*bound);
  if (llt.info() != Eigen::Success) return;
  std::mt19937_64 rng(o.seed);
  std::normal_distribution<double> normal;
  for (int k = 0; k < kBoundDraws; ++k) {
    Vector6d z;
    for (int i = 0; i < 6; ++i)
      z[i] = normal(rng);
    const Vector6d e = llt.matrixL() * z;  // (d_t, d_theta)
    out.translation.push_back(e.head<3>().norm());
    out.rotation.push_back(e.tail<3>().norm());
  }
}

}  // namespace

std::span<const OpencvMethod> opencv_methods() {
  static constexpr std::array<OpencvMethod, 5> kMethods = {{
      {cv::CALIB_HAND_EYE_TSAI, "opencv-TSAI"},
      {cv::CALIB_HAND_EYE_PARK, "opencv-PARK"},
      {cv::CALIB_HAND_EYE_HORAUD, "opencv-HORAUD"},
      {cv::CALIB_HAND_EYE_ANDREFF, "opencv-ANDREFF"},
      {cv::CALIB_HAND_EYE_DANIILIDIS, "opencv-DANIILIDIS"},
  }};
  return kMethods;
}

SE3 opencv_hand_eye(std::span<const Registration> registrations,
                    cv::HandEyeCalibrationMethod method) {
  std::vector<cv::Mat> r_gripper2base, t_gripper2base, r_target2cam, t_target2cam;
  for (const Registration& r : registrations) {
    r_gripper2base.push_back(to_cv(r.vr_from_device.rotation()));
    t_gripper2base.push_back(to_cv(r.vr_from_device.translation()));
    const SE3 marker_from_camera = r.camera_from_marker.inverse();
    r_target2cam.push_back(to_cv(marker_from_camera.rotation()));
    t_target2cam.push_back(to_cv(marker_from_camera.translation()));
  }
  cv::Mat r_out, t_out;
  cv::calibrateHandEye(r_gripper2base, t_gripper2base, r_target2cam, t_target2cam, r_out, t_out,
                       method);
  Eigen::Matrix3d rotation;
  Eigen::Vector3d translation;
  cv::cv2eigen(r_out, rotation);
  cv::cv2eigen(t_out, translation);
  return SE3(SO3::from_matrix(rotation), translation);
}

std::vector<MethodErrors> compare_methods(const SimulationOptions& base, int trials,
                                          const Options& options, const std::string& our_name,
                                          bool with_opencv) {
  std::vector<MethodErrors> out(1);
  out[0].name = our_name;
  if (with_opencv) {
    for (const OpencvMethod& m : opencv_methods())
      out.push_back({m.name, {}, {}, {}});
  }
  // The bound holds for outlier-free data with a known scale.
  const bool with_bound = with_opencv && base.outlier_fraction == 0.0 && !options.estimate_scale;
  if (with_bound) out.push_back({std::string(kCramerRaoName), {}, {}, {}});
  for (int trial = 0; trial < trials; ++trial) {
    SimulationOptions o = base;
    o.seed = base.seed + static_cast<std::uint64_t>(trial);
    const Simulation sim = simulate(o);
    PoseError ours{std::numbers::pi, 1.0};
    double sigma_error = 1.0;
    try {
      const Summary s = solve(sim.registrations, options);
      if (s.is_solution_usable()) {
        ours = pose_error(s.device_from_marker, sim.device_from_marker);
        sigma_error = std::abs(s.sigma - sim.scale);
      }
    } catch (const Error&) {
      // Degenerate session: counted with the worst error above.
    }
    out[0].rotation.push_back(ours.rotation);
    out[0].translation.push_back(ours.translation);
    if (options.estimate_scale) out[0].sigma.push_back(sigma_error);
    if (!with_opencv) continue;
    for (std::size_t m = 0; m < opencv_methods().size(); ++m) {
      const PoseError e = pose_error(opencv_hand_eye(sim.registrations, opencv_methods()[m].method),
                                     sim.device_from_marker);
      out[m + 1].rotation.push_back(e.rotation);
      out[m + 1].translation.push_back(e.translation);
    }
    if (with_bound) add_bound_draws(sim, o, out.back());
  }
  return out;
}

}  // namespace coloc::registration::handeye
