#include "slam/frame/rolling_shutter.hpp"

#include "slam/core/so3.hpp"

namespace coloc::slam::frame {

void compensate_rolling_shutter(features::OrbFeatures& features, const RollingShutter& shutter,
                                const Eigen::Vector3d& omega_cam, double fx, double fy, double cx,
                                double cy) {
  if (!(shutter.readout > 0.0) || shutter.rows <= 0) return;
  const double half = 0.5 * (shutter.rows - 1);
  for (features::Keypoint& kp : features.keypoints) {
    // Rows are read top to bottom; the timestamp stands for the middle row.
    const double tau = (kp.y - half) / shutter.rows * shutter.readout;
    const Eigen::Vector3d bearing((kp.ux - cx) / fx, (kp.uy - cy) / fy, 1.0);
    const Eigen::Vector3d at_middle = SO3::exp(omega_cam * tau) * bearing;
    if (at_middle.z() <= 1e-9) continue;
    kp.ux = static_cast<float>(fx * at_middle.x() / at_middle.z() + cx);
    kp.uy = static_cast<float>(fy * at_middle.y() / at_middle.z() + cy);
  }
}

}  // namespace coloc::slam::frame
