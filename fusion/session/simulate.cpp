#include "fusion/session/simulate.hpp"

#include "slam/core/error.hpp"

namespace coloc::fusion::session {

namespace he = registration::handeye;

SystemModel vive_model() {
  return {"VIVE Pro", ParticipantKind::kVr, 0.0004, 0.0002, 0.0, 0.0, 0.0};
}
SystemModel quest_model() {
  return {"Quest 2", ParticipantKind::kVr, 0.0015, 0.0008, 0.002, 0.0005, 20.0};
}
SystemModel tablet_model() {
  return {"AR tablet", ParticipantKind::kAr, 0.002, 0.001, 0.004, 0.001, 20.0};
}

void MultiUserOptions::check() const {
  const auto require = [](bool ok, const char* field) {
    if (!ok) {
      throw Error("out of range", ErrorContext{.field = std::string("MultiUserOptions.") + field});
    }
  };
  require(participants >= 2 && participants <= 8, "participants");
  require(duration > 2.0, "duration");
  require(rate > 0.0, "rate");
  require(global_sigma >= 0.0, "global_sigma");
  require(registrations >= 3, "registrations");
  require(occluded_fraction >= 0.0 && occluded_fraction <= 1.0, "occluded_fraction");
  require(trials >= 1, "trials");
}

Matrix6d vr_from_camera_covariance(std::span<const he::Registration> regs,
                                   const std::vector<bool>& used, const SE3& device_from_marker,
                                   const SE3& vr_from_camera, const Matrix6d& x_covariance) {
  const SE3 camera_from_vr = vr_from_camera.inverse();
  const auto eps = [&](const he::Registration& r, const SE3& x) {
    return (camera_from_vr * r.vr_from_device * x * r.camera_from_marker.inverse()).log();
  };
  std::vector<Vector6d> samples;
  Matrix6d jacobian = Matrix6d::Zero();
  constexpr double kStep = 1e-6;
  for (std::size_t i = 0; i < regs.size(); ++i) {
    if (i < used.size() && !used[i]) continue;
    const Vector6d e0 = eps(regs[i], device_from_marker);
    samples.push_back(e0);
    for (int c = 0; c < 6; ++c) {
      // X's perturbation as handeye::Summary defines it: (Exp(d_theta) R, t + d_t).
      Eigen::Vector3d dt = Eigen::Vector3d::Zero(), dtheta = Eigen::Vector3d::Zero();
      (c < 3 ? dt : dtheta)[c % 3] = kStep;
      const SE3 x(SO3::exp(dtheta) * device_from_marker.so3(),
                  device_from_marker.translation() + dt);
      jacobian.col(c) += (eps(regs[i], x) - e0) / kStep;
    }
  }
  const auto n = static_cast<double>(samples.size());
  if (samples.size() < 2) return Matrix6d::Identity() * 1e6;  // nothing to predict from
  jacobian /= n;
  Vector6d mean = Vector6d::Zero();
  for (const Vector6d& e : samples)
    mean += e / n;
  Matrix6d spread = Matrix6d::Zero();
  for (const Vector6d& e : samples)
    spread += (e - mean) * (e - mean).transpose() / (n - 1.0);
  return jacobian * x_covariance * jacobian.transpose() + spread / n;
}

StabilityRow stability_row(const std::vector<SE3>& a, const std::vector<SE3>& b,
                           const SE3& vr_a_from_camera, const SE3& vr_b_from_camera) {
  StabilityRow row;
  if (a.empty()) return row;
  const he::Dispersion d =
      he::locked_controller_stability(a, b, vr_a_from_camera, vr_b_from_camera);
  row.rotation_mean = Eigen::AngleAxisd(d.mean.quaternion()).angle();
  row.rotation_mean_abs = d.rotation_mean_abs;
  row.rotation_rms = d.rotation_rms;
  row.translation_mean = d.mean.translation().norm();
  row.translation_mean_abs = d.translation_mean_abs;
  row.translation_rms = d.translation_rms;
  row.poses = a.size();
  return row;
}

}  // namespace coloc::fusion::session
