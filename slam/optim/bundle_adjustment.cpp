#include "slam/optim/bundle_adjustment.hpp"

#include <ceres/loss_function.h>
#include <ceres/normal_prior.h>
#include <ceres/problem.h>
#include <ceres/solver.h>
#include <ceres/sphere_manifold.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <memory>

#include "slam/core/error.hpp"
#include "slam/core/timing.hpp"
#include "slam/optim/dense_schur_lm.hpp"
#include "slam/optim/gravity_cost.hpp"
#include "slam/optim/gyro_cost.hpp"

namespace coloc::slam::optim {

void BundleOptions::check() const {
  if (iterations_robust < 0 || iterations_refine < 0) throw Error("BundleOptions.iterations_* < 0");
  if (!(chi2_stereo > 0.0)) throw Error("BundleOptions.chi2_stereo must be > 0");
  if (!(chi2_mono > 0.0)) throw Error("BundleOptions.chi2_mono must be > 0");
  if (!(chi2_inertial > 0.0)) throw Error("BundleOptions.chi2_inertial must be > 0");
  if (dense_schur_max_poses < 0) throw Error("BundleOptions.dense_schur_max_poses must be >= 0");
}

void pose_to_array(const SE3& pose, double* x) {
  const Eigen::Vector3d& t = pose.translation();
  const Eigen::Quaterniond& q = pose.quaternion();
  x[0] = t.x();
  x[1] = t.y();
  x[2] = t.z();
  x[3] = q.x();
  x[4] = q.y();
  x[5] = q.z();
  x[6] = q.w();
}

SE3 pose_from_array(const double* x) {
  return SE3(Eigen::Quaterniond(x[6], x[3], x[4], x[5]).normalized(),
             Eigen::Vector3d(x[0], x[1], x[2]));
}

bool PoseManifold::Plus(const double* x, const double* delta, double* out) const {
  const Vector6d d = Eigen::Map<const Vector6d>(delta);
  pose_to_array(SE3::exp(d) * pose_from_array(x), out);
  return true;
}

bool PoseManifold::PlusJacobian(const double*, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, 7, 6, Eigen::RowMajor>> j(jacobian);
  j.setZero();
  j.topRows<6>().setIdentity();
  return true;
}

bool PoseManifold::Minus(const double* y, const double* x, double* out) const {
  Eigen::Map<Vector6d> m(out);
  m = (pose_from_array(y) * pose_from_array(x).inverse()).log();
  return true;
}

bool PoseManifold::MinusJacobian(const double*, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, 6, 7, Eigen::RowMajor>> j(jacobian);
  j.setZero();
  j.leftCols<6>().setIdentity();
  return true;
}

namespace {

// Returns false when the point is behind the camera (the residual is then a constant).
template <int kRows, typename Residual, typename Obs>
bool evaluate_cost(const Intrinsics& k, const Obs& obs, double inv_sigma,
                   double const* const* params, double* residuals, double** jacobians,
                   Residual residual_fn) {
  const SE3 pose = pose_from_array(params[0]);
  const Eigen::Vector3d world(params[1][0], params[1][1], params[1][2]);
  const Eigen::Vector3d p = pose * world;
  Eigen::Matrix<double, kRows, 1> r;
  Eigen::Matrix<double, kRows, 3> jr;
  if (!residual_fn(k, p, obs, r, &jr)) {
    // Behind the camera: a large constant residual with zero slope keeps the solver sane.
    for (int i = 0; i < kRows; ++i)
      residuals[i] = 1e3;
    if (jacobians) {
      if (jacobians[0]) std::fill(jacobians[0], jacobians[0] + std::ptrdiff_t{kRows} * 7, 0.0);
      if (jacobians[1]) std::fill(jacobians[1], jacobians[1] + std::ptrdiff_t{kRows} * 3, 0.0);
    }
    return false;
  }
  Eigen::Map<Eigen::Matrix<double, kRows, 1>> res(residuals);
  res = inv_sigma * r;
  if (jacobians) {
    if (jacobians[0]) {
      Eigen::Map<Eigen::Matrix<double, kRows, 7, Eigen::RowMajor>> j(jacobians[0]);
      j.template leftCols<6>() = inv_sigma * jr * pcam_jacobian_pose(p);
      j.col(6).setZero();
    }
    if (jacobians[1]) {
      Eigen::Map<Eigen::Matrix<double, kRows, 3, Eigen::RowMajor>> jp(jacobians[1]);
      jp = inv_sigma * jr * pose.rotation();
    }
  }
  return true;
}

class AbortCallback : public ceres::IterationCallback {
 public:
  explicit AbortCallback(const std::atomic<bool>* flag) : flag_(flag) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    return (flag_ && flag_->load()) ? ceres::SOLVER_TERMINATE_SUCCESSFULLY : ceres::SOLVER_CONTINUE;
  }

 private:
  const std::atomic<bool>* flag_;
};

bool stereo_fn(const Intrinsics& k, const Eigen::Vector3d& p, const Eigen::Vector3d& o,
               Eigen::Vector3d& r, Eigen::Matrix3d* j) {
  return stereo_residual(k, p, o, r, j);
}

bool mono_fn(const Intrinsics& k, const Eigen::Vector3d& p, const Eigen::Vector2d& o,
             Eigen::Vector2d& r, Eigen::Matrix<double, 2, 3>* j) {
  return mono_residual(k, p, o, r, j);
}

}  // namespace

bool StereoReprojectionCost::Evaluate(double const* const* parameters, double* residuals,
                                      double** jacobians) const {
  evaluate_cost<3>(k_, obs_, inv_sigma_, parameters, residuals, jacobians, stereo_fn);
  return true;
}

bool MonoReprojectionCost::Evaluate(double const* const* parameters, double* residuals,
                                    double** jacobians) const {
  evaluate_cost<2>(k_, obs_, inv_sigma_, parameters, residuals, jacobians, mono_fn);
  return true;
}

template <int kRows>
bool ShutterReprojectionCost<kRows>::Evaluate(double const* const* parameters, double* residuals,
                                              double** jacobians) const {
  const bool want_delta = jacobians && jacobians[2];
  Eigen::Vector3d d_obs;
  const Eigen::Vector3d obs =
      shutter_shifted(k_, obs_, shear_, parameters[2][0], want_delta ? &d_obs : nullptr);
  bool in_front = false;
  if constexpr (kRows == 3) {
    in_front = evaluate_cost<3>(k_, obs, inv_sigma_, parameters, residuals, jacobians, stereo_fn);
  } else {
    in_front = evaluate_cost<2>(k_, Eigen::Vector2d(obs.head<2>()), inv_sigma_, parameters,
                                residuals, jacobians, mono_fn);
  }
  if (want_delta) {
    // residual = observed - predicted: it moves with the observation.
    for (int i = 0; i < kRows; ++i)
      jacobians[2][i] = in_front ? inv_sigma_ * d_obs[i] : 0.0;
  }
  return true;
}

template class ShutterReprojectionCost<2>;
template class ShutterReprojectionCost<3>;

namespace {

// The observation (u, v, u_r) as the readout change `delta` has it.
Eigen::Vector3d observed(const Intrinsics& k, const BundleProblem::Observation& o, double delta) {
  Eigen::Vector3d raw(o.pixel.x(), o.pixel.y(), o.u_right);
  if (delta == 0.0 || o.shear.isZero()) return raw;
  return shutter_shifted(k, raw, o.shear, delta, nullptr);
}

// The unknowns besides poses and points, each a parameter only when the problem has it.
struct Extras {
  double delta = 0.0;  // readout change (seconds)
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  std::vector<Eigen::Vector3d> accel_bias;  // per Gravity::bias
  std::vector<Eigen::Vector3d> gyro_bias;   // per pose
  // Per problem.gravity / problem.gyro entry: left out of the second pass.
  std::vector<std::uint8_t> gravity_outlier, gyro_outlier;
};

void add_gravity(const BundleProblem& problem, std::vector<double>& pose_params, Extras& x,
                 bool robust, ceres::Manifold* sphere, ceres::Problem& ceres_problem) {
  const BundleProblem::GravityModel& m = problem.gravity_model;
  for (std::size_t i = 0; i < problem.gravity.size(); ++i) {
    if (x.gravity_outlier[i]) continue;
    const BundleProblem::Gravity& g = problem.gravity[i];
    double* pose = &pose_params[std::size_t{7} * g.pose];
    // A pose without an observation in this solve is not a parameter block yet.
    if (!ceres_problem.HasParameterBlock(pose)) continue;
    // A window whose walker stumbled (a knock on the sensor) must not tilt its keyframe.
    ceres_problem.AddResidualBlock(
        new GravityCost(g.specific_force_cam, g.accel_world, m.magnitude, m.sigma),
        robust ? new ceres::HuberLoss(3.0) : nullptr, pose, x.up.data(),
        x.accel_bias[g.bias].data());
  }
  if (!ceres_problem.HasParameterBlock(x.up.data())) return;
  ceres_problem.SetManifold(x.up.data(), sphere);
  for (Eigen::Vector3d& bias : x.accel_bias) {
    if (!ceres_problem.HasParameterBlock(bias.data())) continue;
    ceres_problem.AddResidualBlock(
        new ceres::NormalPrior(Eigen::Matrix3d::Identity() / m.accel_bias_sigma,
                               Eigen::Vector3d::Zero()),
        nullptr, bias.data());
  }
}

void add_gyro(const BundleProblem& problem, std::vector<double>& pose_params, Extras& x,
              bool robust, ceres::Problem& ceres_problem) {
  const BundleProblem::GyroModel& m = problem.gyro_model;
  // Each chain of pairs (one per recording) starts at a pose no pair ends at: its bias has no
  // walk behind it to hold it, so it takes the prior.
  std::vector<std::uint8_t> ends(problem.poses.size(), 0);
  for (const BundleProblem::Gyro& g : problem.gyro)
    ends[g.pose_b] = 1;
  std::vector<double*> starts;
  for (std::size_t i = 0; i < problem.gyro.size(); ++i) {
    const BundleProblem::Gyro& g = problem.gyro[i];
    double* a = &pose_params[std::size_t{7} * g.pose_a];
    double* b = &pose_params[std::size_t{7} * g.pose_b];
    // Poses without an observation in this solve are not parameter blocks: no gauge to hold.
    if (!ceres_problem.HasParameterBlock(a) || !ceres_problem.HasParameterBlock(b)) continue;
    double* bias_a = x.gyro_bias[g.pose_a].data();
    double* bias_b = x.gyro_bias[g.pose_b].data();
    const double sigma = m.noise_density * std::sqrt(g.dt);
    // A saturated or knocked gyro must not bend the map (the bias still walks across it).
    if (!x.gyro_outlier[i])
      ceres_problem.AddResidualBlock(new GyroCost(g.cam_a_from_cam_b, g.bias_jacobian, sigma),
                                     robust ? new ceres::HuberLoss(3.0) : nullptr, a, b, bias_a);
    const double walk = m.random_walk * std::sqrt(g.dt);
    ceres_problem.AddResidualBlock(new GyroBiasWalkCost(walk), nullptr, bias_a, bias_b);
    if (!ends[g.pose_a] && std::find(starts.begin(), starts.end(), bias_a) == starts.end())
      starts.push_back(bias_a);
  }
  for (double* bias : starts)
    ceres_problem.AddResidualBlock(
        new ceres::NormalPrior(Eigen::Matrix3d::Identity() / m.bias_sigma, Eigen::Vector3d::Zero()),
        nullptr, bias);
}

// Points eliminated first, everything else in the reduced system. Ceres' own ordering takes an
// independent set of the blocks, smallest degree first, and a block that ties poses only (the
// gravity's up direction, an accelerometer or gyro bias) is independent of every point, so it
// was eliminated with them: the Schur complement then tied every keyframe to every other, a
// dense reduced system. The final global BA of a 1,400-keyframe site took over five minutes.
std::shared_ptr<ceres::ParameterBlockOrdering> points_first(BundleProblem& problem,
                                                            const ceres::Problem& ceres_problem) {
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  std::vector<double*> blocks;
  ceres_problem.GetParameterBlocks(&blocks);
  for (double* block : blocks)
    ordering->AddElementToGroup(block, 1);
  for (auto& point : problem.points) {
    if (ceres_problem.HasParameterBlock(point.data())) ordering->AddElementToGroup(point.data(), 0);
  }
  return ordering;
}

std::ptrdiff_t free_poses(const BundleProblem& problem) {
  return std::count_if(problem.poses.begin(), problem.poses.end(),
                       [](const BundleProblem::Pose& p) { return !p.fixed; });
}

// One Ceres solve over the observations not flagged in `skip`; the readout change is a
// parameter when the problem estimates the readout. Returns iterations run.
int solve_ceres(BundleProblem& problem, std::vector<double>& pose_params, Extras& x,
                const Intrinsics& k, const BundleOptions& options,
                const std::vector<std::uint8_t>& skip, bool robust, int iterations,
                const std::atomic<bool>* abort, BundleResult& result) {
  double& delta = x.delta;
  const Stopwatch build;
  ceres::Problem::Options popts;
  popts.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem ceres_problem(popts);
  PoseManifold manifold;
  std::vector<std::uint8_t> used_pose(problem.poses.size(), 0);
  for (std::size_t i = 0; i < problem.observations.size(); ++i) {
    if (skip[i]) continue;
    const auto& o = problem.observations[i];
    double* pose = &pose_params[std::size_t{7} * o.pose];
    double* point = problem.points[o.point].data();
    const double inv_sigma = std::sqrt(o.inv_sigma2);
    ceres::LossFunction* loss = nullptr;
    const bool stereo = o.u_right >= 0.0;
    if (robust)
      loss = new ceres::HuberLoss(std::sqrt(stereo ? options.chi2_stereo : options.chi2_mono));
    if (problem.readout.estimate && !o.shear.isZero()) {
      const Eigen::Vector3d obs(o.pixel.x(), o.pixel.y(), o.u_right);
      ceres::CostFunction* cost =
          stereo ? static_cast<ceres::CostFunction*>(
                       new ShutterReprojectionCost<3>(k, obs, o.shear, inv_sigma))
                 : new ShutterReprojectionCost<2>(k, obs, o.shear, inv_sigma);
      ceres_problem.AddResidualBlock(cost, loss, pose, point, &delta);
    } else if (stereo) {
      ceres_problem.AddResidualBlock(
          new StereoReprojectionCost(k, {o.pixel.x(), o.pixel.y(), o.u_right}, inv_sigma), loss,
          pose, point);
    } else {
      ceres_problem.AddResidualBlock(new MonoReprojectionCost(k, o.pixel, inv_sigma), loss, pose,
                                     point);
    }
    if (!used_pose[o.pose]) {
      used_pose[o.pose] = 1;
      ceres_problem.SetManifold(pose, &manifold);
      if (problem.poses[o.pose].fixed) ceres_problem.SetParameterBlockConstant(pose);
    }
  }
  if (ceres_problem.NumResidualBlocks() == 0) return 0;
  ceres::SphereManifold<3> sphere;
  add_gravity(problem, pose_params, x, robust, &sphere, ceres_problem);
  add_gyro(problem, pose_params, x, robust, ceres_problem);
  if (ceres_problem.HasParameterBlock(&delta)) {
    const BundleProblem::Readout& r = problem.readout;
    const Eigen::Matrix<double, 1, 1> a =
        Eigen::Matrix<double, 1, 1>::Constant(1.0 / r.prior_sigma);
    ceres_problem.AddResidualBlock(
        new ceres::NormalPrior(a, Eigen::VectorXd::Constant(1, r.prior - r.current)), nullptr,
        &delta);
    ceres_problem.SetParameterLowerBound(&delta, 0, r.min - r.current);
    ceres_problem.SetParameterUpperBound(&delta, 0, r.max - r.current);
  }
  ceres::Solver::Options sopts;
  sopts.linear_solver_type = free_poses(problem) <= options.dense_schur_max_poses
                                 ? ceres::DENSE_SCHUR
                                 : ceres::SPARSE_SCHUR;
  if (!problem.gravity.empty() || !problem.gyro.empty())
    sopts.linear_solver_ordering = points_first(problem, ceres_problem);
  sopts.max_num_iterations = iterations;
  sopts.num_threads = 1;
  sopts.logging_type = ceres::SILENT;
  AbortCallback callback(abort);
  sopts.callbacks.push_back(&callback);
  ceres::Solver::Summary summary;
  result.timing.build_ms += build.elapsed_ms();
  ceres::Solve(sopts, &ceres_problem, &summary);
  result.timing.preprocess_ms += 1e3 * summary.preprocessor_time_in_seconds;
  result.timing.evaluate_ms += 1e3 * (summary.residual_evaluation_time_in_seconds +
                                      summary.jacobian_evaluation_time_in_seconds);
  result.timing.linear_solver_ms += 1e3 * summary.linear_solver_time_in_seconds;
  if (result.iterations == 0) result.initial_cost = summary.initial_cost;
  result.final_cost = summary.final_cost;
  return static_cast<int>(summary.iterations.size());
}

// One solve: our dense-Schur LM where it applies (dense_schur_lm.hpp), Ceres otherwise.
int solve(BundleProblem& problem, std::vector<double>& pose_params, Extras& x, const Intrinsics& k,
          const BundleOptions& options, const std::vector<std::uint8_t>& skip, bool robust,
          int iterations, const std::atomic<bool>* abort, BundleResult& result) {
  if (!options.own_dense_solver || free_poses(problem) > options.dense_schur_max_poses ||
      !dense_schur_applies(problem))
    return solve_ceres(problem, pose_params, x, k, options, skip, robust, iterations, abort,
                       result);
  const DenseSchurPass pass{robust, iterations, options.chi2_stereo, options.chi2_mono};
  const DenseSchurStats stats =
      dense_schur_solve(problem, pose_params, x.delta, k, skip, pass, abort);
  result.timing.build_ms += stats.build_ms;
  result.timing.evaluate_ms += stats.evaluate_ms;
  result.timing.linear_solver_ms += stats.linear_solver_ms;
  if (result.iterations == 0) result.initial_cost = stats.initial_cost;
  result.final_cost = stats.final_cost;
  return stats.iterations;
}

// Flags (never unflags) the observations beyond the chi2 thresholds at the current estimate,
// and those behind their camera, as ORB-SLAM does.
void flag_outliers(const BundleProblem& problem, const std::vector<double>& pose_params,
                   double delta, const Intrinsics& k, const BundleOptions& options,
                   std::vector<std::uint8_t>& outlier) {
  for (std::size_t i = 0; i < problem.observations.size(); ++i) {
    const auto& o = problem.observations[i];
    const SE3 pose = pose_from_array(&pose_params[std::size_t{7} * o.pose]);
    const Eigen::Vector3d p = pose * problem.points[o.point];
    const Eigen::Vector3d obs = observed(k, o, delta);
    double chi2 = -1.0;
    bool bad = false;
    if (o.u_right >= 0.0) {
      Eigen::Vector3d r;
      if (stereo_residual(k, p, obs, r, nullptr)) chi2 = r.squaredNorm() * o.inv_sigma2;
      bad = chi2 < 0.0 || chi2 > options.chi2_stereo;
    } else {
      Eigen::Vector2d r;
      if (mono_residual(k, p, obs.head<2>(), r, nullptr)) chi2 = r.squaredNorm() * o.inv_sigma2;
      bad = chi2 < 0.0 || chi2 > options.chi2_mono;
    }
    if (bad) outlier[i] = 1;
  }
}

// One gravity window's residual (m/s^2) and one gyro pair's (rad) at the current estimate, not
// whitened; NaN where the cost cannot be evaluated.
Eigen::Vector3d gravity_residual(const BundleProblem& problem, const BundleProblem::Gravity& g,
                                 const std::vector<double>& pose_params, const Extras& x) {
  const GravityCost cost(g.specific_force_cam, g.accel_world, problem.gravity_model.magnitude, 1.0);
  const double* params[3] = {&pose_params[std::size_t{7} * g.pose], x.up.data(),
                             x.accel_bias[g.bias].data()};
  Eigen::Vector3d r;
  if (!cost.Evaluate(params, r.data(), nullptr)) r.setConstant(std::nan(""));
  return r;
}

Eigen::Vector3d gyro_residual(const BundleProblem::Gyro& g, const std::vector<double>& pose_params,
                              const Extras& x) {
  const GyroCost cost(g.cam_a_from_cam_b, g.bias_jacobian, 1.0);
  const double* params[3] = {&pose_params[std::size_t{7} * g.pose_a],
                             &pose_params[std::size_t{7} * g.pose_b], x.gyro_bias[g.pose_a].data()};
  Eigen::Vector3d r;
  if (!cost.Evaluate(params, r.data(), nullptr)) r.setConstant(std::nan(""));
  return r;
}

// Flags (never unflags) the gravity windows and gyro pairs whose whitened residual exceeds
// chi2_inertial at the current estimate (or cannot be evaluated). Returns whether it flagged any.
bool flag_inertial_outliers(const BundleProblem& problem, const std::vector<double>& pose_params,
                            const BundleOptions& options, Extras& x) {
  bool flagged = false;
  auto judge = [&](std::uint8_t& outlier, const Eigen::Vector3d& r, double sigma) {
    if (outlier || r.squaredNorm() / (sigma * sigma) <= options.chi2_inertial) return;
    outlier = 1;  // NaN compares false above, so it lands here too
    flagged = true;
  };
  for (std::size_t i = 0; i < problem.gravity.size(); ++i)
    judge(x.gravity_outlier[i], gravity_residual(problem, problem.gravity[i], pose_params, x),
          problem.gravity_model.sigma);
  for (std::size_t i = 0; i < problem.gyro.size(); ++i) {
    const BundleProblem::Gyro& g = problem.gyro[i];
    judge(x.gyro_outlier[i], gyro_residual(g, pose_params, x),
          problem.gyro_model.noise_density * std::sqrt(g.dt));
  }
  return flagged;
}

// RMS length of the residuals of the entries not flagged (0 without any).
template <typename Entry, typename Residual>
double rms_kept(const std::vector<Entry>& entries, const std::vector<std::uint8_t>& outlier,
                Residual residual) {
  double sum = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < entries.size(); ++i) {
    if (outlier[i]) continue;
    sum += residual(entries[i]).squaredNorm();
    ++n;
  }
  return n > 0 ? std::sqrt(sum / static_cast<double>(n)) : 0.0;
}

}  // namespace

BundleResult bundle_adjust(BundleProblem& problem, const Intrinsics& k,
                           const BundleOptions& options, const std::atomic<bool>* abort) {
  options.check();
  const Stopwatch total;
  BundleResult result;
  result.outlier.assign(problem.observations.size(), 0);
  std::vector<double> pose_params(7 * problem.poses.size());
  for (std::size_t i = 0; i < problem.poses.size(); ++i)
    pose_to_array(problem.poses[i].cam_from_world, &pose_params[7 * i]);

  Extras x;
  if (!problem.gyro.empty()) x.gyro_bias.assign(problem.poses.size(), Eigen::Vector3d::Zero());
  x.gravity_outlier.assign(problem.gravity.size(), 0);
  x.gyro_outlier.assign(problem.gyro.size(), 0);
  if (!problem.gravity.empty()) {
    std::uint32_t biases = 0;
    for (const BundleProblem::Gravity& g : problem.gravity)
      biases = std::max(biases, g.bias + 1);
    x.accel_bias.assign(biases, Eigen::Vector3d::Zero());
    // Up starts as the mean of what each keyframe's measurement says it is.
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const BundleProblem::Gravity& g : problem.gravity)
      sum += problem.poses[g.pose].cam_from_world.rotation().transpose() * g.specific_force_cam -
             g.accel_world;
    if (sum.norm() > 0.0) x.up = sum.normalized();
  }
  result.iterations += solve(problem, pose_params, x, k, options, result.outlier, true,
                             options.iterations_robust, abort, result);
  // Even under its kernel a gyro pair far off pulls the poses it joins apart, and the frames'
  // observations across that link would then look like outliers: without such pairs, the
  // robust pass runs again before the observations are judged.
  if (flag_inertial_outliers(problem, pose_params, options, x) && !(abort && abort->load()))
    result.iterations += solve(problem, pose_params, x, k, options, result.outlier, true,
                               options.iterations_robust, abort, result);
  flag_outliers(problem, pose_params, x.delta, k, options, result.outlier);
  if (!(abort && abort->load()) && options.iterations_refine > 0) {
    result.iterations += solve(problem, pose_params, x, k, options, result.outlier, false,
                               options.iterations_refine, abort, result);
    // ORB-SLAM2 checks every observation again after the refinement: a wrong match the kernel
    // hid by splitting its error with the right ones shows once it pulls with full weight.
    flag_outliers(problem, pose_params, x.delta, k, options, result.outlier);
  }
  result.readout_change = x.delta;
  if (!problem.gravity.empty()) {
    result.up_world = x.up;
    result.accel_bias = x.accel_bias;  // copied: gravity_residual below still reads them
  }
  result.gravity_rms = rms_kept(problem.gravity, x.gravity_outlier, [&](const auto& g) {
    return gravity_residual(problem, g, pose_params, x);
  });
  result.gyro_rms = rms_kept(problem.gyro, x.gyro_outlier,
                             [&](const auto& g) { return gyro_residual(g, pose_params, x); });
  result.gyro_bias = std::move(x.gyro_bias);
  result.gravity_outlier = std::move(x.gravity_outlier);
  result.gyro_outlier = std::move(x.gyro_outlier);
  result.aborted = abort && abort->load();
  for (std::size_t i = 0; i < problem.poses.size(); ++i) {
    problem.poses[i].cam_from_world = pose_from_array(&pose_params[7 * i]);
  }
  result.timing.total_ms = total.elapsed_ms();
  return result;
}

}  // namespace coloc::slam::optim
