#include "registration/handeye/compose.hpp"

#include <algorithm>
#include <cmath>

#include "registration/handeye/linear.hpp"
#include "slam/core/error.hpp"

namespace coloc::registration::handeye {

std::vector<SE3> vr_from_camera_per_registration(std::span<const Registration> registrations,
                                                 const SE3& device_from_marker, double sigma) {
  std::vector<SE3> out;
  out.reserve(registrations.size());
  for (const Registration& r : registrations) {
    out.push_back(r.vr_from_device * device_from_marker *
                  scaled(r.camera_from_marker, sigma).inverse());
  }
  return out;
}

SE3 chordal_mean(std::span<const SE3> poses) {
  if (poses.empty()) return SE3();
  Eigen::Matrix3d rotation_sum = Eigen::Matrix3d::Zero();
  Eigen::Vector3d translation_sum = Eigen::Vector3d::Zero();
  for (const SE3& pose : poses) {
    rotation_sum += pose.rotation();
    translation_sum += pose.translation();
  }
  // SO3::from_matrix projects onto SO(3) by SVD: the chordal L2 mean.
  return SE3(SO3::from_matrix(rotation_sum), translation_sum / static_cast<double>(poses.size()));
}

SE3 vr_b_from_vr_a(const SE3& vr_a_from_camera, const SE3& vr_b_from_camera) {
  return vr_b_from_camera * vr_a_from_camera.inverse();
}

Dispersion dispersion(std::span<const SE3> poses) {
  Dispersion d;
  d.mean = chordal_mean(poses);
  if (poses.empty()) return d;
  const SE3 mean_inverse = d.mean.inverse();
  for (const SE3& pose : poses) {
    const double rotation = (mean_inverse * pose).so3().angle();
    const double translation = (pose.translation() - d.mean.translation()).norm();
    d.rotation_mean_abs += rotation;
    d.rotation_rms += rotation * rotation;
    d.rotation_max = std::max(d.rotation_max, rotation);
    d.translation_mean_abs += translation;
    d.translation_rms += translation * translation;
    d.translation_max = std::max(d.translation_max, translation);
  }
  const double n = static_cast<double>(poses.size());
  d.rotation_mean_abs /= n;
  d.translation_mean_abs /= n;
  d.rotation_rms = std::sqrt(d.rotation_rms / n);
  d.translation_rms = std::sqrt(d.translation_rms / n);
  return d;
}

Dispersion locked_controller_stability(std::span<const SE3> vr_a_from_device_a,
                                       std::span<const SE3> vr_b_from_device_b,
                                       const SE3& vr_a_from_camera, const SE3& vr_b_from_camera) {
  if (vr_a_from_device_a.size() != vr_b_from_device_b.size() || vr_a_from_device_a.empty()) {
    throw Error(
        "locked-controller stability needs the same, non-zero number of poses from "
        "both systems (got " +
            std::to_string(vr_a_from_device_a.size()) + " and " +
            std::to_string(vr_b_from_device_b.size()) + ")",
        {.field = "vr_b_from_device_b"});
  }
  const SE3 vr_b_from_vr_a_pose = vr_b_from_vr_a(vr_a_from_camera, vr_b_from_camera);
  std::vector<SE3> relative;
  relative.reserve(vr_a_from_device_a.size());
  for (std::size_t i = 0; i < vr_a_from_device_a.size(); ++i) {
    relative.push_back(vr_b_from_device_b[i].inverse() * vr_b_from_vr_a_pose *
                       vr_a_from_device_a[i]);
  }
  return dispersion(relative);
}

}  // namespace coloc::registration::handeye
