#include "slam/frame/rolling_shutter.hpp"

#include <Eigen/Cholesky>

#include "slam/core/so3.hpp"

namespace coloc::slam::frame {

void compensate_rolling_shutter(features::OrbFeatures& features, const RollingShutter& shutter,
                                const Eigen::Vector3d& omega_cam, double fx, double fy, double cx,
                                double cy) {
  // A negative readout undoes a compensation (Frame::set_shutter_readout).
  if (shutter.readout == 0.0 || shutter.rows <= 0) return;
  for (features::Keypoint& kp : features.keypoints) {
    const double tau = row_time(kp.y, shutter);
    const Eigen::Vector3d bearing((kp.ux - cx) / fx, (kp.uy - cy) / fy, 1.0);
    const Eigen::Vector3d at_middle = SO3::exp(omega_cam * tau) * bearing;
    if (at_middle.z() <= 1e-9) continue;
    kp.ux = static_cast<float>(fx * at_middle.x() / at_middle.z() + cx);
    kp.uy = static_cast<float>(fy * at_middle.y() / at_middle.z() + cy);
  }
}

double row_time(double row, const RollingShutter& shutter) {
  // Rows are read top to bottom; the timestamp stands for the middle row.
  return (row - 0.5 * (shutter.rows - 1)) / shutter.rows * shutter.readout;
}

Eigen::Vector3d estimate_rotation_rate(const std::vector<RateObservation>& observations,
                                       const Eigen::Vector3d& prior, double prior_sigma, double fx,
                                       double fy, double cx, double cy) {
  if (observations.size() < 20 || !(prior_sigma > 0.0)) return prior;
  Eigen::Vector3d omega = prior;
  const double prior_weight = 1.0 / (prior_sigma * prior_sigma);
  for (int it = 0; it < 3; ++it) {
    Eigen::Matrix3d h = prior_weight * Eigen::Matrix3d::Identity();
    Eigen::Vector3d b = -prior_weight * (omega - prior);
    for (const RateObservation& o : observations) {
      const Eigen::Vector3d bearing((o.pixel.x() - cx) / fx, (o.pixel.y() - cy) / fy, 1.0);
      const Eigen::Vector3d q = SO3::exp(omega * o.tau) * bearing;
      if (q.z() <= 1e-9 || o.point_cam.z() <= 1e-9) continue;
      const Eigen::Vector2d predicted(fx * o.point_cam.x() / o.point_cam.z() + cx,
                                      fy * o.point_cam.y() / o.point_cam.z() + cy);
      const Eigen::Vector2d compensated(fx * q.x() / q.z() + cx, fy * q.y() / q.z() + cy);
      const Eigen::Vector2d r = o.inv_sigma * (compensated - predicted);
      // d compensated / d omega (small rotation about the current estimate: d q = -[q]x tau dw).
      Eigen::Matrix<double, 2, 3> dproj;
      dproj << fx / q.z(), 0.0, -fx * q.x() / (q.z() * q.z()), 0.0, fy / q.z(),
          -fy * q.y() / (q.z() * q.z());
      const Eigen::Matrix<double, 2, 3> j = o.inv_sigma * dproj * (-SO3::hat(q) * o.tau);
      // Huber at 2.45 px (the 2-dof chi2 at 95 %) keeps stray matches from steering the rate.
      const double e = r.norm();
      const double w = e > 2.45 ? 2.45 / e : 1.0;
      h.noalias() += w * j.transpose() * j;
      b.noalias() -= w * j.transpose() * r;
    }
    const Eigen::Vector3d step = h.ldlt().solve(b);
    if (!step.allFinite()) return prior;
    omega += step;
    if (step.norm() < 1e-4) break;
  }
  return omega;
}

}  // namespace coloc::slam::frame
