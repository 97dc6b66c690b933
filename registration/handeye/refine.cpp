#include "registration/handeye/refine.hpp"

#include <ceres/ceres.h>

#include <array>
#include <cmath>

#include "registration/handeye/linear.hpp"

namespace coloc::registration::handeye {

namespace {

// Residual of one registration: 3 rotation + 3 translation components of the marker pose in
// the camera, divided by their standard deviations.
struct RegistrationCost {
  Eigen::Quaterniond q_vr_from_device;
  Eigen::Vector3d t_vr_from_device;
  Eigen::Quaterniond q_camera_from_marker;
  Eigen::Vector3d t_camera_from_marker;
  double inv_rotation_sigma = 1.0;
  // Whitens the translation residual (camera frame); anisotropic along the viewing ray.
  Eigen::Matrix3d translation_whitening = Eigen::Matrix3d::Identity();

  template <typename T>
  bool operator()(const T* q_x_data, const T* t_x_data, const T* q_y_data, const T* t_y_data,
                  const T* sigma, T* residual) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q_x(q_x_data);  // device_from_marker
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t_x(t_x_data);
    const Eigen::Map<const Eigen::Quaternion<T>> q_y(q_y_data);  // vr_from_camera
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t_y(t_y_data);
    const Eigen::Quaternion<T> q_d = q_vr_from_device.cast<T>();
    const Eigen::Quaternion<T> q_y_inv = q_y.conjugate();
    // Predicted camera_from_marker = vr_from_camera^-1 * vr_from_device * device_from_marker.
    const Eigen::Quaternion<T> q_pred = q_y_inv * (q_d * q_x);
    const Eigen::Matrix<T, 3, 1> t_pred = q_y_inv * (q_d * t_x + t_vr_from_device.cast<T>() - t_y);
    Eigen::Quaternion<T> dq = q_pred.conjugate() * q_camera_from_marker.cast<T>();
    const T sign = dq.w() < T(0) ? T(-1) : T(1);
    const Eigen::Matrix<T, 3, 1> rotation = T(2) * sign * dq.vec();  // ~ Log(dq), small angles
    const Eigen::Matrix<T, 3, 1> translation =
        translation_whitening.cast<T>() * (sigma[0] * t_camera_from_marker.cast<T>() - t_pred);
    for (int k = 0; k < 3; ++k) {
      residual[k] = rotation[k] * T(inv_rotation_sigma);
      residual[3 + k] = translation[k];
    }
    return true;
  }
};

// Copies a covariance block of two tangent-space parameter blocks into the (d_t, d_theta) layout.
// Ceres' quaternion tangent delta is half the rotation vector, hence the factors of 2.
Matrix6d assemble_covariance(const ceres::Covariance& covariance, const double* q, const double* t,
                             bool& ok) {
  std::array<double, 9> tt{}, qq{}, tq{};
  ok = covariance.GetCovarianceBlockInTangentSpace(t, t, tt.data()) &&
       covariance.GetCovarianceBlockInTangentSpace(q, q, qq.data()) &&
       covariance.GetCovarianceBlockInTangentSpace(t, q, tq.data());
  Matrix6d out = Matrix6d::Zero();
  out.topLeftCorner<3, 3>() =
      Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(tt.data());
  out.bottomRightCorner<3, 3>() =
      4.0 * Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(qq.data());
  out.topRightCorner<3, 3>() =
      2.0 * Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(tq.data());
  out.bottomLeftCorner<3, 3>() = out.topRightCorner<3, 3>().transpose();
  return out;
}

}  // namespace

std::pair<double, double> registration_residual(const Registration& registration,
                                                const SE3& device_from_marker,
                                                const SE3& vr_from_camera, double sigma) {
  const SE3 predicted = vr_from_camera.inverse() * registration.vr_from_device * device_from_marker;
  const SE3 measured = scaled(registration.camera_from_marker, sigma);
  return {angular_distance(predicted.so3(), measured.so3()),
          (predicted.translation() - measured.translation()).norm()};
}

NoiseModel noise_from_residuals(std::span<const Registration> registrations,
                                const std::vector<bool>& used, const SE3& device_from_marker,
                                const SE3& vr_from_camera, double sigma, int parameters) {
  double rotation = 0.0, lateral = 0.0, depth = 0.0;
  int n = 0;
  for (std::size_t k = 0; k < registrations.size(); ++k) {
    if (!used[k]) continue;
    const Registration& r = registrations[k];
    const SE3 predicted = vr_from_camera.inverse() * r.vr_from_device * device_from_marker;
    const SE3 measured = scaled(r.camera_from_marker, sigma);
    const double angle = angular_distance(predicted.so3(), measured.so3());
    const Eigen::Vector3d e = measured.translation() - predicted.translation();
    const double along = e.dot(measured.translation().normalized());
    rotation += angle * angle;
    depth += along * along;
    lateral += e.squaredNorm() - along * along;
    ++n;
  }
  const double correction = 6.0 * n / std::max(1.0, 6.0 * n - parameters);
  NoiseModel m;
  constexpr double kTiny = 1e-9;  // the device terms are folded into the marker terms
  m.device_rotation = kTiny;
  m.device_translation = kTiny;
  m.marker_rotation = std::max(kTiny, std::sqrt(correction * rotation / (3.0 * n)));
  // A separate depth term costs n degrees of freedom of the variance estimate: with ~10
  // registrations a chance excess of the depth residuals would weight depth down and lose
  // accuracy, so depth gets its own standard deviation only when its variance exceeds the
  // lateral one significantly (F-test: F(n, 2n) stays below ~2.5 at 95 % for n >= 6).
  constexpr double kDepthSignificance = 2.5;
  const double lateral_variance = lateral / (2.0 * n);
  const double depth_variance = depth / n;
  if (depth_variance > kDepthSignificance * lateral_variance) {
    m.marker_translation = std::max(kTiny, std::sqrt(correction * lateral_variance));
    m.marker_depth = std::sqrt(correction * std::max(0.0, depth_variance - lateral_variance));
  } else {
    m.marker_translation = std::max(kTiny, std::sqrt(correction * (lateral + depth) / (3.0 * n)));
    m.marker_depth = 0.0;
  }
  return m;
}

namespace {

// The parameter blocks Ceres optimizes in place.
struct Parameters {
  Eigen::Quaterniond q_x;  // device_from_marker
  Eigen::Vector3d t_x;
  Eigen::Quaterniond q_y;  // vr_from_camera
  Eigen::Vector3d t_y;
  double sigma = 1.0;
};

ceres::CostFunction* make_cost(const Registration& r, const NoiseModel& noise, double lever) {
  const double rotation_sigma = std::hypot(noise.device_rotation, noise.marker_rotation);
  // Device rotation noise moves the marker by the lever arm |t_X|.
  const double translation_sigma =
      std::sqrt(noise.device_translation * noise.device_translation +
                noise.marker_translation * noise.marker_translation +
                noise.device_rotation * noise.device_rotation * lever * lever);
  // Lateral and depth standard deviations; whitening W = P_lat / s_lat + P_ray / s_depth.
  const Eigen::Vector3d ray = r.camera_from_marker.translation().normalized();
  const Eigen::Matrix3d along = ray * ray.transpose();
  const double depth_sigma = std::hypot(translation_sigma, noise.marker_depth);
  const Eigen::Matrix3d whitening =
      (Eigen::Matrix3d::Identity() - along) / translation_sigma + along / depth_sigma;
  return new ceres::AutoDiffCostFunction<RegistrationCost, 6, 4, 3, 4, 3, 1>(
      new RegistrationCost{r.vr_from_device.quaternion(), r.vr_from_device.translation(),
                           r.camera_from_marker.quaternion(), r.camera_from_marker.translation(),
                           1.0 / rotation_sigma, whitening});
}

void compute_covariance(ceres::Problem& problem, Parameters& p, bool with_scale,
                        RefineResult& result) {
  ceres::Covariance::Options covariance_options;
  covariance_options.algorithm_type = ceres::DENSE_SVD;
  covariance_options.num_threads = 1;
  ceres::Covariance covariance(covariance_options);
  double* q = p.q_x.coeffs().data();
  std::vector<std::pair<const double*, const double*>> blocks = {
      {p.t_x.data(), p.t_x.data()}, {q, q}, {p.t_x.data(), q}};
  if (with_scale) blocks.emplace_back(&p.sigma, &p.sigma);
  if (!covariance.Compute(blocks, &problem)) return;
  bool ok = false;
  const Matrix6d c = assemble_covariance(covariance, q, p.t_x.data(), ok);
  if (ok) result.device_from_marker_covariance = result.variance_factor * c;
  double sigma_variance = 0.0;
  if (with_scale && covariance.GetCovarianceBlock(&p.sigma, &p.sigma, &sigma_variance)) {
    result.sigma_variance = result.variance_factor * sigma_variance;
  }
}

// Adds one residual block per used registration; returns how many.
int add_residuals(ceres::Problem& problem, std::span<const Registration> registrations,
                  const std::vector<bool>& used, const NoiseModel& noise, ceres::LossFunction* loss,
                  ceres::Manifold* quaternion_manifold, bool estimate_scale, Parameters& p) {
  int residual_blocks = 0;
  for (std::size_t k = 0; k < registrations.size(); ++k) {
    if (!used[k]) continue;
    problem.AddResidualBlock(make_cost(registrations[k], noise, p.t_x.norm()), loss,
                             p.q_x.coeffs().data(), p.t_x.data(), p.q_y.coeffs().data(),
                             p.t_y.data(), &p.sigma);
    ++residual_blocks;
  }
  if (residual_blocks == 0) return 0;
  problem.SetManifold(p.q_x.coeffs().data(), quaternion_manifold);
  problem.SetManifold(p.q_y.coeffs().data(), quaternion_manifold);
  if (!estimate_scale) problem.SetParameterBlockConstant(&p.sigma);
  return residual_blocks;
}

ceres::Problem::Options borrowing_problem_options() {
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  return problem_options;
}

}  // namespace

std::optional<Matrix6d> cramer_rao_bound(std::span<const Registration> registrations,
                                         const std::vector<bool>& used,
                                         const SE3& device_from_marker, const SE3& vr_from_camera,
                                         double sigma, const NoiseModel& noise,
                                         bool estimate_scale) {
  Parameters p{device_from_marker.quaternion(), device_from_marker.translation(),
               vr_from_camera.quaternion(), vr_from_camera.translation(), sigma};
  ceres::Problem problem(borrowing_problem_options());
  ceres::EigenQuaternionManifold quaternion_manifold;
  const int blocks = add_residuals(problem, registrations, used, noise, nullptr,
                                   &quaternion_manifold, estimate_scale, p);
  if (6 * blocks <= 12 + (estimate_scale ? 1 : 0)) return std::nullopt;
  RefineResult result;  // variance_factor 1: the noise model is taken as the truth
  compute_covariance(problem, p, estimate_scale, result);
  return result.device_from_marker_covariance;
}

RefineResult refine(std::span<const Registration> registrations, const std::vector<bool>& used,
                    const SE3& device_from_marker, const SE3& vr_from_camera, double sigma,
                    const Options& options) {
  Parameters p{device_from_marker.quaternion(), device_from_marker.translation(),
               vr_from_camera.quaternion(), vr_from_camera.translation(), sigma};
  ceres::Problem problem(borrowing_problem_options());
  ceres::EigenQuaternionManifold quaternion_manifold;
  ceres::HuberLoss huber(options.huber_delta > 0 ? options.huber_delta : 1.0);
  // Huber in robust mode only: at Gaussian noise it down-weights ~17 % of the inlier blocks
  // (chi^2 with 6 dof exceeds 3^2 that often) and costs ~2 % accuracy against plain ML.
  ceres::LossFunction* loss = options.robust && options.huber_delta > 0 ? &huber : nullptr;
  const int residual_blocks = add_residuals(problem, registrations, used, options.noise, loss,
                                            &quaternion_manifold, options.estimate_scale, p);
  RefineResult result{device_from_marker, vr_from_camera, sigma};
  if (residual_blocks == 0) return result;

  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.max_num_iterations = options.max_refine_iterations;
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);

  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.iterations = static_cast<int>(summary.iterations.size());
  result.device_from_marker = SE3(p.q_x, p.t_x);
  result.vr_from_camera = SE3(p.q_y, p.t_y);
  result.sigma = p.sigma;
  const int dof = 6 * residual_blocks - (12 + (options.estimate_scale ? 1 : 0));
  result.variance_factor = dof > 0 ? 2.0 * summary.final_cost / dof : 1.0;
  if (options.estimate_covariance && result.converged && dof > 0) {
    compute_covariance(problem, p, options.estimate_scale, result);
  }
  return result;
}

}  // namespace coloc::registration::handeye
