#pragma once
// Baselines and evaluation against OpenCV's cv::calibrateHandEye (separate target
// coloc_handeye_opencv, so coloc_handeye itself stays free of OpenCV). Frames as in
// registration/handeye/handeye.hpp.

#include <opencv2/calib3d.hpp>
#include <span>
#include <string>
#include <vector>

#include "registration/handeye/handeye.hpp"
#include "registration/handeye/simulate.hpp"

namespace coloc::registration::handeye {

// device_from_marker by cv::calibrateHandEye. Mapping to OpenCV's eye-in-hand problem
// (base_from_gripper * gripper_from_cam * cam_from_target = const): gripper = device,
// cam = marker, target = camera, so R_gripper2base = vr_from_device, R_target2cam =
// camera_from_marker^-1, and OpenCV's cam2gripper is device_from_marker.
SE3 opencv_hand_eye(std::span<const Registration> registrations,
                    cv::HandEyeCalibrationMethod method);

struct OpencvMethod {
  cv::HandEyeCalibrationMethod method;
  const char* name;
};
// TSAI, PARK, HORAUD, ANDREFF, DANIILIDIS.
std::span<const OpencvMethod> opencv_methods();

// Errors of one method over many simulated sessions (rad, m, and |sigma - truth| if estimated).
struct MethodErrors {
  std::string name;
  std::vector<double> rotation;
  std::vector<double> translation;
  std::vector<double> sigma;
};

// Name of the pseudo-method holding the Cramer-Rao bound (see compare_methods()).
inline constexpr const char* kCramerRaoName = "Cramer-Rao bound";

// Runs `trials` sessions (seeds base.seed, base.seed + 1, ...) and solves each with ours
// (`options`, named `our_name`) and, if with_opencv, with every OpenCV method. A session our
// solver rejects (degenerate) or marks unusable counts with an error of pi rad / 1 m. With
// with_opencv on outlier-free data and a known scale, a last row kCramerRaoName holds errors drawn
// from each session's Cramer-Rao bound (cramer_rao_bound() at the truth, simulated noise): what
// an efficient unbiased estimator achieves on the same sessions.
std::vector<MethodErrors> compare_methods(const SimulationOptions& base, int trials,
                                          const Options& options, const std::string& our_name,
                                          bool with_opencv);

}  // namespace coloc::registration::handeye
