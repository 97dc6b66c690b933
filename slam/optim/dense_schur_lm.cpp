#include "slam/optim/dense_schur_lm.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <cstddef>

#include "slam/core/timing.hpp"

namespace coloc::slam::optim {
namespace {

using Matrix63 = Eigen::Matrix<double, 6, 3>;
using Matrix36 = Eigen::Matrix<double, 3, 6>;

// Ceres' defaults, so both solvers stop where the other would.
constexpr double kInitialMu = 1e-4;  // 1 / initial_trust_region_radius
constexpr double kMaxMu = 1e32;      // 1 / min_trust_region_radius: give up
constexpr double kMinMu = 1e-16;     // 1 / max_trust_region_radius
constexpr double kMinDiagonal = 1e-6, kMaxDiagonal = 1e32;
constexpr double kMinRelativeDecrease = 1e-3;
constexpr double kFunctionTolerance = 1e-6, kGradientTolerance = 1e-10;
constexpr double kParameterTolerance = 1e-8;
// The residual of an observation behind its camera (each row), as the Ceres costs give it.
constexpr double kBehindResidual = 1e3;

// Which unknowns are in the solve, and the observations grouped by point.
struct Layout {
  // Per problem pose: the offset of its 6 unknowns in the reduced system, or -1 (fixed, or no
  // observation in this solve).
  std::vector<Eigen::Index> pose_offset;
  Eigen::Index readout = -1;  // index of the readout change in the reduced system, or -1
  Eigen::Index size = 0;      // dimension of the reduced system
  std::vector<std::uint32_t> point_begin;  // CSR over points into `observations`
  std::vector<std::uint32_t> observations;
  std::vector<Eigen::Index> offset;  // per entry of `observations`: its pose's offset, or -1
};

Layout make_layout(const BundleProblem& problem, const std::vector<std::uint8_t>& skip) {
  Layout l;
  l.pose_offset.assign(problem.poses.size(), -1);
  std::vector<std::uint32_t> count(problem.points.size() + 1, 0);
  bool sheared = false;
  for (std::size_t i = 0; i < problem.observations.size(); ++i) {
    if (skip[i]) continue;
    const BundleProblem::Observation& o = problem.observations[i];
    if (!problem.poses[o.pose].fixed && l.pose_offset[o.pose] < 0) {
      l.pose_offset[o.pose] = l.size;
      l.size += 6;
    }
    ++count[o.point + 1];
    sheared = sheared || !o.shear.isZero();
  }
  if (problem.readout.estimate && sheared) l.readout = l.size++;
  for (std::size_t j = 1; j < count.size(); ++j)
    count[j] += count[j - 1];
  l.point_begin = count;
  l.observations.resize(count.back());
  for (std::size_t i = 0; i < problem.observations.size(); ++i) {
    if (!skip[i])
      l.observations[count[problem.observations[i].point]++] = static_cast<std::uint32_t>(i);
  }
  l.offset.resize(l.observations.size());
  for (std::size_t a = 0; a < l.observations.size(); ++a)
    l.offset[a] = l.pose_offset[problem.observations[l.observations[a]].pose];
  return l;
}

struct State {
  std::vector<SE3> cam_from_world;
  std::vector<Eigen::Vector3d> points;
  double delta = 0.0;
};

// The normal equations at one estimate, points not yet eliminated: U over the reduced system's
// unknowns (upper triangle), V per point, W per observation (pose x point), Wd per point
// (readout x point), and the gradients J^T r. All weighted by the robust kernel.
struct Normal {
  Eigen::MatrixXd u;
  Eigen::VectorXd g_reduced;
  std::vector<Eigen::Matrix3d> v;
  std::vector<Eigen::Vector3d> g_point;
  std::vector<Matrix63> w;  // in Layout::observations order
  std::vector<Eigen::RowVector3d> wd;
};

struct Evaluator {
  const BundleProblem& problem;
  const Layout& layout;
  const Intrinsics& k;
  const DenseSchurPass& pass;

  // The cost at `s`; with `n`, the normal equations too.
  double operator()(const State& s, Normal* n) const {
    std::vector<Eigen::Matrix3d> rotation(s.cam_from_world.size());
    for (std::size_t i = 0; i < rotation.size(); ++i)
      rotation[i] = s.cam_from_world[i].rotation();
    if (n) {
      n->u.setZero(layout.size, layout.size);
      n->g_reduced.setZero(layout.size);
      n->v.assign(problem.points.size(), Eigen::Matrix3d::Zero());
      n->g_point.assign(problem.points.size(), Eigen::Vector3d::Zero());
      n->w.resize(layout.observations.size());
      if (layout.readout >= 0) n->wd.assign(problem.points.size(), Eigen::RowVector3d::Zero());
    }
    double cost = 0.0;
    for (std::size_t a = 0; a < layout.observations.size(); ++a) {
      const BundleProblem::Observation& o = problem.observations[layout.observations[a]];
      cost += observation(s, rotation[o.pose], o, a, n);
    }
    if (layout.readout >= 0) {
      const BundleProblem::Readout& r = problem.readout;
      const double inv_sigma = 1.0 / r.prior_sigma;
      const double res = inv_sigma * (s.delta - (r.prior - r.current));
      cost += 0.5 * res * res;
      if (n) {
        n->u(layout.readout, layout.readout) += inv_sigma * inv_sigma;
        n->g_reduced(layout.readout) += inv_sigma * res;
      }
    }
    return cost;
  }

  // One observation's cost; with `n`, its share of the normal equations.
  double observation(const State& s, const Eigen::Matrix3d& rotation,
                     const BundleProblem::Observation& o, std::size_t a, Normal* n) const {
    const bool stereo = o.u_right >= 0.0;
    const bool sheared = layout.readout >= 0 && !o.shear.isZero();
    const int rows = stereo ? 3 : 2;
    Eigen::Vector3d obs(o.pixel.x(), o.pixel.y(), o.u_right);
    Eigen::Vector3d d_obs = Eigen::Vector3d::Zero();
    if (sheared) obs = shutter_shifted(k, obs, o.shear, s.delta, n ? &d_obs : nullptr);
    const Eigen::Vector3d p = rotation * s.points[o.point] + s.cam_from_world[o.pose].translation();
    Eigen::Vector3d r = Eigen::Vector3d::Zero();
    Eigen::Matrix3d jr = Eigen::Matrix3d::Zero();
    bool in_front = false;
    if (stereo) {
      in_front = stereo_residual(k, p, obs, r, n ? &jr : nullptr);
    } else {
      Eigen::Vector2d r2;
      Eigen::Matrix<double, 2, 3> j2;
      in_front = mono_residual(k, p, obs.head<2>(), r2, n ? &j2 : nullptr);
      r.head<2>() = r2;
      if (n) jr.topRows<2>() = j2;
    }
    const double chi2 = stereo ? pass.chi2_stereo : pass.chi2_mono;
    if (!in_front) {
      if (n) n->w[a].setZero();
      return 0.5 * rho(rows * kBehindResidual * kBehindResidual, chi2, nullptr);
    }
    const double inv_sigma = std::sqrt(o.inv_sigma2);
    r *= inv_sigma;
    double weight = 1.0;
    const double cost = 0.5 * rho(r.squaredNorm(), chi2, &weight);
    if (!n) return cost;
    jr *= inv_sigma;
    const Matrix36 jp = jr * pcam_jacobian_pose(p);
    const Eigen::Matrix3d jx = jr * rotation;
    const Eigen::Matrix<double, 6, 3> wjp_t = weight * jp.transpose();
    const Eigen::Matrix3d wjx_t = weight * jx.transpose();
    n->v[o.point].noalias() += wjx_t * jx;
    n->g_point[o.point].noalias() += wjx_t * r;
    const Eigen::Index at = layout.offset[a];
    if (at >= 0) {
      n->u.block<6, 6>(at, at).noalias() += wjp_t * jp;
      n->g_reduced.segment<6>(at).noalias() += wjp_t * r;
      n->w[a].noalias() = wjp_t * jx;
    } else {
      n->w[a].setZero();
    }
    if (sheared) {
      // residual = observed - predicted: it moves with the observation.
      const Eigen::Vector3d jd = inv_sigma * d_obs.cwiseProduct(Eigen::Vector3d(1.0, 1.0, stereo));
      const Eigen::Index d = layout.readout;
      n->u(d, d) += weight * jd.squaredNorm();
      n->g_reduced(d) += weight * jd.dot(r);
      n->wd[o.point].noalias() += weight * jd.transpose() * jx;
      if (at >= 0) n->u.block<6, 1>(at, d).noalias() += wjp_t * jd;
    }
    return cost;
  }

  // Huber of the squared residual `s` (threshold sqrt(chi2)) in the robust pass, `s` otherwise;
  // `weight` (may be null) is rho'(s), the IRLS weight.
  double rho(double s, double chi2, double* weight) const {
    if (!pass.robust || s <= chi2) {
      if (weight) *weight = 1.0;
      return s;
    }
    const double a = std::sqrt(chi2), root = std::sqrt(s);
    if (weight) *weight = a / root;
    return 2.0 * a * root - chi2;
  }
};

double clamped_diagonal(double d) {
  return std::clamp(d, kMinDiagonal, kMaxDiagonal);
}

// A damped step: (J^T J + mu D) step = -g with the points eliminated. Returns false when the
// reduced system is not positive definite. The predicted cost decrease goes to `predicted`.
bool solve_step(const Layout& layout, const Normal& n, double mu, Eigen::VectorXd& step_reduced,
                std::vector<Eigen::Vector3d>& step_point, double& predicted) {
  Eigen::MatrixXd s = n.u;
  Eigen::VectorXd rhs = -n.g_reduced;
  for (Eigen::Index i = 0; i < layout.size; ++i)
    s(i, i) += mu * clamped_diagonal(n.u(i, i));
  const std::size_t points = layout.point_begin.size() - 1;
  std::vector<Eigen::Matrix3d> v_inv(points);
  std::vector<std::uint8_t> eliminated(points, 0);
  std::vector<Matrix63> y;
  for (std::size_t j = 0; j < points; ++j) {
    const std::uint32_t begin = layout.point_begin[j], end = layout.point_begin[j + 1];
    if (begin == end) continue;
    Eigen::Matrix3d v = n.v[j];
    for (int i = 0; i < 3; ++i)
      v(i, i) += mu * clamped_diagonal(n.v[j](i, i));
    bool invertible = false;
    v.computeInverseWithCheck(v_inv[j], invertible, 1e-300);
    if (!invertible) continue;  // this step leaves the point where it is
    eliminated[j] = 1;
    const Eigen::Vector3d rhs_point = -n.g_point[j];
    y.resize(end - begin);
    for (std::uint32_t a = begin; a < end; ++a)
      y[a - begin].noalias() = n.w[a] * v_inv[j];
    Eigen::RowVector3d yd = Eigen::RowVector3d::Zero();
    if (layout.readout >= 0) {
      yd.noalias() = n.wd[j] * v_inv[j];
      rhs(layout.readout) -= yd.dot(rhs_point);
      s(layout.readout, layout.readout) -= yd.dot(n.wd[j]);
    }
    for (std::uint32_t a = begin; a < end; ++a) {
      const Eigen::Index at_a = layout.offset[a];
      if (at_a < 0) continue;
      const Matrix63& ya = y[a - begin];
      rhs.segment<6>(at_a).noalias() -= ya * rhs_point;
      if (layout.readout >= 0)
        s.block<6, 1>(at_a, layout.readout).noalias() -= ya * n.wd[j].transpose();
      for (std::uint32_t b = begin; b < end; ++b) {
        const Eigen::Index at_b = layout.offset[b];
        if (at_b < at_a) continue;  // the upper triangle only
        s.block<6, 6>(at_a, at_b).noalias() -= ya * n.w[b].transpose();
      }
    }
  }
  const Eigen::LLT<Eigen::MatrixXd, Eigen::Upper> llt(s);
  if (llt.info() != Eigen::Success) return false;
  step_reduced = llt.solve(rhs);
  if (!step_reduced.allFinite()) return false;
  // Back-substitution, and the model's decrease 1/2 step^T (mu D step - g) over all unknowns.
  predicted = 0.0;
  for (Eigen::Index i = 0; i < layout.size; ++i) {
    const double d = step_reduced(i);
    predicted += 0.5 * d * (mu * clamped_diagonal(n.u(i, i)) * d - n.g_reduced(i));
  }
  step_point.assign(points, Eigen::Vector3d::Zero());
  for (std::size_t j = 0; j < points; ++j) {
    if (!eliminated[j]) continue;
    Eigen::Vector3d rhs_point = -n.g_point[j];
    for (std::uint32_t a = layout.point_begin[j]; a < layout.point_begin[j + 1]; ++a) {
      const Eigen::Index at = layout.offset[a];
      if (at >= 0) rhs_point.noalias() -= n.w[a].transpose() * step_reduced.segment<6>(at);
    }
    if (layout.readout >= 0) rhs_point -= n.wd[j].transpose() * step_reduced(layout.readout);
    step_point[j].noalias() = v_inv[j] * rhs_point;
    for (int i = 0; i < 3; ++i) {
      const double d = step_point[j](i);
      predicted += 0.5 * d * (mu * clamped_diagonal(n.v[j](i, i)) * d - n.g_point[j](i));
    }
  }
  return true;
}

// The largest entry of the gradient: Ceres' gradient tolerance compares it.
double gradient_max_norm(const Normal& n) {
  double gradient = n.g_reduced.size() > 0 ? n.g_reduced.lpNorm<Eigen::Infinity>() : 0.0;
  for (const Eigen::Vector3d& g : n.g_point)
    gradient = std::max(gradient, g.lpNorm<Eigen::Infinity>());
  return gradient;
}

// Ceres' parameter tolerance: the step is negligible against the estimate.
bool negligible(const Layout& layout, const State& s, const Eigen::VectorXd& step_reduced,
                const std::vector<Eigen::Vector3d>& step_point) {
  double step_norm2 = step_reduced.squaredNorm(), x_norm2 = 0.0;
  for (std::size_t j = 0; j < step_point.size(); ++j) {
    step_norm2 += step_point[j].squaredNorm();
    x_norm2 += s.points[j].squaredNorm();
  }
  for (std::size_t i = 0; i < s.cam_from_world.size(); ++i) {
    if (layout.pose_offset[i] >= 0)  // + 1: the unit quaternion
      x_norm2 += s.cam_from_world[i].translation().squaredNorm() + 1.0;
  }
  return std::sqrt(step_norm2) <= kParameterTolerance * (std::sqrt(x_norm2) + kParameterTolerance);
}

// `s` moved by a step: poses left-multiplied (PoseManifold), the readout held in its bounds.
State stepped(const BundleProblem& problem, const Layout& layout, const State& s,
              const Eigen::VectorXd& step_reduced, const std::vector<Eigen::Vector3d>& step_point) {
  State moved = s;
  for (std::size_t i = 0; i < s.cam_from_world.size(); ++i) {
    const Eigen::Index at = layout.pose_offset[i];
    if (at >= 0)
      moved.cam_from_world[i] = SE3::exp(step_reduced.segment<6>(at)) * s.cam_from_world[i];
  }
  for (std::size_t j = 0; j < step_point.size(); ++j)
    moved.points[j] += step_point[j];
  if (layout.readout >= 0) {
    const BundleProblem::Readout& r = problem.readout;
    moved.delta =
        std::clamp(s.delta + step_reduced(layout.readout), r.min - r.current, r.max - r.current);
  }
  return moved;
}

// The damping mu (1 / Ceres' trust-region radius) and its growth factor.
struct Damping {
  double mu = kInitialMu, nu = 2.0;
  // After a rejected step; false when the region has shrunk to nothing.
  bool reject() {
    mu *= nu;
    nu *= 2.0;
    return mu <= kMaxMu;
  }
  void accept(double gain) {
    mu = std::max(kMinMu, mu * std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * gain - 1.0, 3)));
    nu = 2.0;
  }
};

}  // namespace

bool dense_schur_applies(const BundleProblem& problem) {
  return problem.gravity.empty() && problem.gyro.empty();
}

DenseSchurStats dense_schur_solve(BundleProblem& problem, std::vector<double>& pose_params,
                                  double& readout_change, const Intrinsics& k,
                                  const std::vector<std::uint8_t>& skip, const DenseSchurPass& pass,
                                  const std::atomic<bool>* abort) {
  DenseSchurStats stats;
  const Stopwatch build;
  const Layout layout = make_layout(problem, skip);
  if (layout.observations.empty()) return stats;  // as Ceres: no residual, nothing to solve
  State s;
  s.cam_from_world.reserve(problem.poses.size());
  for (std::size_t i = 0; i < problem.poses.size(); ++i)
    s.cam_from_world.push_back(pose_from_array(&pose_params[7 * i]));
  s.points = problem.points;
  s.delta = readout_change;
  const Evaluator evaluate{problem, layout, k, pass};
  stats.build_ms = build.elapsed_ms();

  Stopwatch watch;
  Normal normal;
  double cost = evaluate(s, &normal);
  stats.evaluate_ms += watch.elapsed_ms();
  stats.initial_cost = cost;
  stats.iterations = 1;
  Damping damping;
  Eigen::VectorXd step_reduced;
  std::vector<Eigen::Vector3d> step_point;
  for (int tried = 0; tried < pass.iterations; ++tried) {
    if ((abort && abort->load()) || gradient_max_norm(normal) <= kGradientTolerance) break;
    double predicted = 0.0;
    watch.restart();
    const bool solved = solve_step(layout, normal, damping.mu, step_reduced, step_point, predicted);
    stats.linear_solver_ms += watch.elapsed_ms();
    if (!solved || !(predicted > 0.0)) {
      ++stats.iterations;
      if (!damping.reject()) break;
      continue;
    }
    if (negligible(layout, s, step_reduced, step_point)) break;
    State candidate = stepped(problem, layout, s, step_reduced, step_point);
    watch.restart();
    const double new_cost = evaluate(candidate, nullptr);
    stats.evaluate_ms += watch.elapsed_ms();
    // Converged when the step changes the cost by less than this share, up or down; as Ceres
    // does, the estimate stays where it was (and the step is not counted).
    if (std::abs(cost - new_cost) <= kFunctionTolerance * cost) break;
    ++stats.iterations;
    const double gain = (cost - new_cost) / predicted;
    if (!std::isfinite(new_cost) || !(gain > kMinRelativeDecrease)) {
      if (!damping.reject()) break;
      continue;
    }
    s = std::move(candidate);
    damping.accept(gain);
    watch.restart();
    cost = evaluate(s, &normal);
    stats.evaluate_ms += watch.elapsed_ms();
  }
  stats.final_cost = cost;
  for (std::size_t i = 0; i < problem.poses.size(); ++i) {
    if (layout.pose_offset[i] >= 0) pose_to_array(s.cam_from_world[i], &pose_params[7 * i]);
  }
  problem.points = std::move(s.points);
  if (layout.readout >= 0) readout_change = s.delta;
  return stats;
}

}  // namespace coloc::slam::optim
