#include "slam/optim/pose_optimizer.hpp"

#include <Eigen/Cholesky>
#include <cmath>

#include "slam/core/error.hpp"

namespace coloc::slam::optim {

void PoseOptimizerOptions::check() const {
  if (rounds < 1) throw Error("PoseOptimizerOptions.rounds must be >= 1");
  if (iterations < 1) throw Error("PoseOptimizerOptions.iterations must be >= 1");
  if (!(chi2_stereo > 0.0)) throw Error("PoseOptimizerOptions.chi2_stereo must be > 0");
  if (!(chi2_mono > 0.0)) throw Error("PoseOptimizerOptions.chi2_mono must be > 0");
}

namespace {

// Chi2 (whitened squared error) of one observation; negative when behind the camera.
double chi2_of(const SE3& pose, const PoseObservation& o, const Intrinsics& k) {
  const Eigen::Vector3d p = pose * o.world;
  if (o.u_right >= 0.0) {
    Eigen::Vector3d r;
    if (!stereo_residual(k, p, {o.pixel.x(), o.pixel.y(), o.u_right}, r, nullptr)) return -1.0;
    return r.squaredNorm() * o.inv_sigma2;
  }
  Eigen::Vector2d r;
  if (!mono_residual(k, p, o.pixel, r, nullptr)) return -1.0;
  return r.squaredNorm() * o.inv_sigma2;
}

}  // namespace

PoseOptimizationResult optimize_pose(const SE3& initial, const std::vector<PoseObservation>& obs,
                                     const Intrinsics& k, const PoseOptimizerOptions& options,
                                     const CentrePrior* prior) {
  options.check();
  if (prior && !(prior->sigma_m > 0.0)) throw Error("CentrePrior.sigma_m must be > 0");
  PoseOptimizationResult result;
  result.cam_from_world = initial;
  result.outlier.assign(obs.size(), 0);
  SE3 pose = initial;
  for (int round = 0; round < options.rounds; ++round) {
    const bool robust = round < options.rounds - 1;
    for (int it = 0; it < options.iterations; ++it) {
      Matrix6d h = Matrix6d::Zero();
      Vector6d b = Vector6d::Zero();
      int used = 0;
      for (std::size_t i = 0; i < obs.size(); ++i) {
        if (result.outlier[i]) continue;
        const PoseObservation& o = obs[i];
        const Eigen::Vector3d p = pose * o.world;
        const Eigen::Matrix<double, 3, 6> dp = pcam_jacobian_pose(p);
        const double delta = std::sqrt(o.u_right >= 0.0 ? options.chi2_stereo : options.chi2_mono);
        auto accumulate = [&](const auto& r, const auto& jr) {
          const double e2 = r.squaredNorm() * o.inv_sigma2;
          const double e = std::sqrt(e2);
          const double w = (robust && e > delta) ? delta / e : 1.0;  // Huber IRLS weight
          const auto j = (jr * dp).eval();
          h.noalias() += (w * o.inv_sigma2) * j.transpose() * j;
          b.noalias() -= (w * o.inv_sigma2) * j.transpose() * r;
          ++used;
        };
        if (o.u_right >= 0.0) {
          Eigen::Vector3d r;
          Eigen::Matrix3d jr;
          if (stereo_residual(k, p, {o.pixel.x(), o.pixel.y(), o.u_right}, r, &jr))
            accumulate(r, jr);
        } else {
          Eigen::Vector2d r;
          Eigen::Matrix<double, 2, 3> jr;
          if (mono_residual(k, p, o.pixel, r, &jr)) accumulate(r, jr);
        }
      }
      if (used < 3) break;
      if (prior) {
        // Centre c = -R^T t; under pose <- exp(dx) * pose it moves by -R^T d_rho (first order).
        const Eigen::Matrix3d rt = pose.rotation().transpose();
        const Eigen::Vector3d r = -rt * pose.translation() - prior->world_centre;
        const double w = 1.0 / (prior->sigma_m * prior->sigma_m);
        h.topLeftCorner<3, 3>() += w * Eigen::Matrix3d::Identity();  // J^T J with J = [-R^T 0]
        b.head<3>() += w * rt.transpose() * r;                       // -J^T r
      }
      const Vector6d dx = h.ldlt().solve(b);
      if (!dx.allFinite()) break;
      pose = SE3::exp(dx) * pose;
      if (dx.squaredNorm() < 1e-12) break;
    }
    // Classify every observation (outliers may come back, as in ORB-SLAM).
    result.inliers = 0;
    for (std::size_t i = 0; i < obs.size(); ++i) {
      const double chi2 = chi2_of(pose, obs[i], k);
      const double th = obs[i].u_right >= 0.0 ? options.chi2_stereo : options.chi2_mono;
      result.outlier[i] = (chi2 < 0.0 || chi2 > th) ? 1 : 0;
      result.inliers += result.outlier[i] ? 0 : 1;
    }
    if (result.inliers < 10 && round >= 1) break;
  }
  result.cam_from_world = pose;
  return result;
}

}  // namespace coloc::slam::optim
