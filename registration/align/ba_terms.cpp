#include "registration/align/ba_terms.hpp"

#include <ceres/loss_function.h>
#include <ceres/solver.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "slam/core/error.hpp"

namespace coloc::registration::align {

namespace optim = slam::optim;

slam::mapping::BaWindow whole_map_window(const slam::map::Map& map) {
  if (map.keyframe_count() < 2) {
    throw Error("the map has " + std::to_string(map.keyframe_count()) +
                    " keyframe(s); bundle adjustment needs two or more",
                {.field = "keyframes"});
  }
  std::vector<KeyframeId> all;
  for (const auto& [id, kf] : map.keyframes())
    all.push_back(id);
  std::sort(all.begin(), all.end());
  return slam::mapping::make_window(map, all);
}

BaState BaState::of(const optim::BundleProblem& p) {
  BaState s;
  s.poses.resize(7 * p.poses.size());
  for (std::size_t i = 0; i < p.poses.size(); ++i)
    optim::pose_to_array(p.poses[i].cam_from_world, &s.poses[7 * i]);
  s.points = p.points;
  return s;
}

SE3 BaState::cam_from_world(std::uint32_t pose) const {
  return optim::pose_from_array(&poses[7 * static_cast<std::size_t>(pose)]);
}

double* PoseBlocks::operator()(std::uint32_t pose) {
  double* block = state_.pose_block(pose);
  if (!added_[pose]) {
    added_[pose] = 1;
    problem_.AddParameterBlock(block, 7, &manifold_);
    if (window_.poses[pose].fixed) problem_.SetParameterBlockConstant(block);
  }
  return block;
}

ceres::Problem::Options ba_problem_options() {
  ceres::Problem::Options o;
  o.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  return o;
}

void add_reprojection_terms(ceres::Problem& problem, const optim::BundleProblem& window,
                            const optim::Intrinsics& k, const std::vector<std::uint8_t>& skip,
                            double huber_delta, BaState& state, PoseBlocks& poses) {
  for (std::size_t i = 0; i < window.observations.size(); ++i) {
    if (skip[i]) continue;
    const auto& ob = window.observations[i];
    const double inv_sigma = std::sqrt(ob.inv_sigma2);
    double* pose = poses(ob.pose);
    double* point = state.points[ob.point].data();
    if (ob.u_right >= 0.0) {
      problem.AddResidualBlock(
          new optim::StereoReprojectionCost(k, {ob.pixel.x(), ob.pixel.y(), ob.u_right}, inv_sigma),
          new ceres::HuberLoss(huber_delta), pose, point);
    } else {
      problem.AddResidualBlock(new optim::MonoReprojectionCost(k, ob.pixel, inv_sigma),
                               new ceres::HuberLoss(huber_delta), pose, point);
    }
  }
}

int solve_ba(ceres::Problem& problem, int iterations, int threads) {
  if (problem.NumResidualBlocks() == 0) return 0;
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::SPARSE_SCHUR;
  so.max_num_iterations = iterations;
  so.num_threads = threads;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  return static_cast<int>(summary.iterations.size());
}

std::vector<std::uint8_t> classify_observations(const optim::BundleProblem& p, const BaState& s,
                                                const optim::Intrinsics& k, double chi2_stereo,
                                                double chi2_mono, double* rms_px) {
  std::vector<std::uint8_t> out(p.observations.size(), 0);
  double sum = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < p.observations.size(); ++i) {
    const auto& ob = p.observations[i];
    const Eigen::Vector3d pc = s.cam_from_world(ob.pose) * s.points[ob.point];
    double chi2 = -1.0, px2 = 0.0;
    if (ob.u_right >= 0.0) {
      Eigen::Vector3d r;
      if (optim::stereo_residual(k, pc, {ob.pixel.x(), ob.pixel.y(), ob.u_right}, r, nullptr)) {
        chi2 = r.squaredNorm() * ob.inv_sigma2;
        px2 = r.head<2>().squaredNorm();
      }
      out[i] = (chi2 < 0.0 || chi2 > chi2_stereo) ? 1 : 0;
    } else {
      Eigen::Vector2d r;
      if (optim::mono_residual(k, pc, ob.pixel, r, nullptr)) {
        chi2 = r.squaredNorm() * ob.inv_sigma2;
        px2 = r.squaredNorm();
      }
      out[i] = (chi2 < 0.0 || chi2 > chi2_mono) ? 1 : 0;
    }
    if (!out[i]) {
      sum += px2;
      ++n;
    }
  }
  if (rms_px) *rms_px = n ? std::sqrt(sum / static_cast<double>(n)) : 0.0;
  return out;
}

double reprojection_rms_px(const optim::BundleProblem& p, const BaState& s,
                           const optim::Intrinsics& k, const std::vector<std::uint8_t>& skip) {
  double sum = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < p.observations.size(); ++i) {
    if (skip[i]) continue;
    const auto& ob = p.observations[i];
    Eigen::Vector2d r;
    if (!optim::mono_residual(k, s.cam_from_world(ob.pose) * s.points[ob.point], ob.pixel, r,
                              nullptr))
      continue;
    sum += r.squaredNorm();
    ++n;
  }
  return n ? std::sqrt(sum / static_cast<double>(n)) : 0.0;
}

void write_back(slam::map::Map& map, slam::mapping::BaWindow& w, const BaState& s,
                const std::vector<std::uint8_t>& outlier) {
  for (std::size_t i = 0; i < w.problem.poses.size(); ++i)
    w.problem.poses[i].cam_from_world = s.cam_from_world(static_cast<std::uint32_t>(i));
  w.problem.points = s.points;
  optim::BundleResult result;
  result.outlier = outlier;
  slam::mapping::apply_window(map, w, result);
}

}  // namespace coloc::registration::align
