#include "slam/core/align.hpp"

#include <Eigen/SVD>
#include <cmath>

#include "slam/core/error.hpp"

namespace coloc {

AlignmentResult align_points(const std::vector<Eigen::Vector3d>& src,
                             const std::vector<Eigen::Vector3d>& dst,
                             const AlignmentOptions& options) {
  if (src.size() != dst.size()) {
    throw Error("align_points: " + std::to_string(src.size()) + " source points but " +
                std::to_string(dst.size()) + " destination points");
  }
  if (!options.weights.empty() && options.weights.size() != src.size()) {
    throw Error("align_points: " + std::to_string(options.weights.size()) + " weights for " +
                std::to_string(src.size()) + " points");
  }
  AlignmentResult result;
  const std::size_t n = src.size();
  auto weight = [&](std::size_t i) { return options.weights.empty() ? 1.0 : options.weights[i]; };

  double w_sum = 0.0;
  Eigen::Vector3d mu_src = Eigen::Vector3d::Zero();
  Eigen::Vector3d mu_dst = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    w_sum += weight(i);
    mu_src += weight(i) * src[i];
    mu_dst += weight(i) * dst[i];
  }
  if (n < 3 || !(w_sum > 0.0)) return result;
  mu_src /= w_sum;
  mu_dst /= w_sum;

  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();  // sum w (dst - mu_dst)(src - mu_src)^T
  double var_src = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d a = src[i] - mu_src;
    const Eigen::Vector3d b = dst[i] - mu_dst;
    cov += weight(i) * b * a.transpose();
    var_src += weight(i) * a.squaredNorm();
  }
  cov /= w_sum;
  var_src /= w_sum;

  Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d& sv = svd.singularValues();
  result.conditioning = sv(0) > 0.0 ? sv(1) / sv(0) : 0.0;
  // Two non-zero singular values determine the rotation (planar sets are fine; lines are not).
  if (!(sv(0) > 0.0) || result.conditioning < 1e-10 || !(var_src > 0.0)) return result;

  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0) d(2, 2) = -1.0;
  const Eigen::Matrix3d r = svd.matrixU() * d * svd.matrixV().transpose();
  const double s = options.estimate_scale ? (sv.asDiagonal() * d).trace() / var_src : 1.0;
  const Eigen::Vector3d t = mu_dst - s * r * mu_src;
  result.dst_from_src = Sim3(s, SO3::from_matrix(r), t);

  double sq = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    sq += weight(i) * (dst[i] - result.dst_from_src * src[i]).squaredNorm();
  }
  result.rmse = std::sqrt(sq / w_sum);
  result.usable = true;
  return result;
}

}  // namespace coloc
