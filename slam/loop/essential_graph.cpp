#include "slam/loop/essential_graph.hpp"

#include <ceres/ceres.h>
#include <spdlog/spdlog.h>

#include <Eigen/Geometry>
#include <set>

#include "slam/optim/bundle_adjustment.hpp"

namespace coloc::slam::loop {
namespace {

// Parameter blocks are optim's pose arrays [tx ty tz qx qy qz qw] of cam_from_world.
struct RelativePoseError {
  explicit RelativePoseError(const SE3& a_from_b)
      : q_meas(a_from_b.quaternion()), t_meas(a_from_b.translation()) {}

  template <typename T>
  bool operator()(const T* a, const T* b, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> qa(a + 3), qb(b + 3);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> ta(a), tb(b);
    const Eigen::Quaternion<T> q_rel = qa * qb.conjugate();
    const Eigen::Matrix<T, 3, 1> t_rel = ta - q_rel * tb;
    const Eigen::Quaternion<T> q_inv = q_meas.conjugate().cast<T>();
    Eigen::Quaternion<T> q_err = q_inv * q_rel;
    const Eigen::Matrix<T, 3, 1> t_err = q_inv * (t_rel - t_meas.cast<T>());
    // q and -q are one rotation: take the one near identity so the residual is small.
    if (q_err.w() < T(0)) q_err.coeffs() = -q_err.coeffs();
    r[0] = t_err.x();
    r[1] = t_err.y();
    r[2] = t_err.z();
    r[3] = T(2) * q_err.x();
    r[4] = T(2) * q_err.y();
    r[5] = T(2) * q_err.z();
    return true;
  }

  Eigen::Quaterniond q_meas;
  Eigen::Vector3d t_meas;
};

using Edge = std::pair<KeyframeId, KeyframeId>;  // (smaller id, larger id)

Edge ordered(KeyframeId a, KeyframeId b) {
  return a < b ? Edge{a, b} : Edge{b, a};
}

// The edges measured with the original poses: tree, loop edges, strong covisibility.
std::set<Edge> odometry_edges(const map::Map& map, int strong) {
  std::set<Edge> edges;
  for (const auto& [id, kf] : map.keyframes()) {
    if (kf.parent.valid() && map.keyframe(kf.parent)) edges.insert(ordered(id, kf.parent));
    for (KeyframeId l : kf.loop_edges)
      if (map.keyframe(l)) edges.insert(ordered(id, l));
    for (const auto& [other, w] : kf.covisibility)
      if (w >= strong && map.keyframe(other)) edges.insert(ordered(id, other));
  }
  return edges;
}

}  // namespace

EssentialGraphReport optimize_essential_graph(map::Map& map, const EssentialGraphInput& input) {
  EssentialGraphReport report;
  std::unordered_map<KeyframeId, std::array<double, 7>> pose;
  for (const auto& [id, kf] : map.keyframes())
    optim::pose_to_array(kf.cam_from_world(), pose[id].data());
  auto measured = [&](KeyframeId k) {
    auto it = input.original.find(k);
    return it != input.original.end() ? it->second : map.keyframe(k)->cam_from_world();
  };
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  // optim::PoseManifold's lifted Jacobian suits analytic costs only; autodiff needs the true
  // plus-Jacobian of translation (Euclidean) and quaternion (xyzw, Eigen order).
  ceres::ProductManifold<ceres::EuclideanManifold<3>, ceres::EigenQuaternionManifold> manifold;
  auto add_edge = [&](KeyframeId a, KeyframeId b, const SE3& a_from_b) {
    auto* cost = new ceres::AutoDiffCostFunction<RelativePoseError, 6, 7, 7>(
        new RelativePoseError(a_from_b));
    problem.AddResidualBlock(cost, nullptr, pose[a].data(), pose[b].data());
    ++report.edges;
  };
  std::set<Edge> loop_set;
  for (const auto& [a, b] : input.loop_connections) {
    if (!map.keyframe(a) || !map.keyframe(b) || a == b) continue;
    if (!loop_set.insert(ordered(a, b)).second) continue;
    add_edge(a, b, map.keyframe(a)->cam_from_world() * map.keyframe(b)->cam_from_world().inverse());
  }
  for (const auto& [a, b] : odometry_edges(map, input.strong_covisibility)) {
    if (loop_set.count({a, b})) continue;
    add_edge(a, b, measured(a) * measured(b).inverse());
  }
  for (auto& [id, x] : pose) {
    if (!problem.HasParameterBlock(x.data())) continue;
    problem.SetManifold(x.data(), &manifold);
    if (id == input.fixed) problem.SetParameterBlockConstant(x.data());
  }
  report.keyframes = static_cast<std::size_t>(problem.NumParameterBlocks());
  if (report.edges == 0 || !map.keyframe(input.fixed)) return report;
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  options.max_num_iterations = input.iterations;
  options.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  spdlog::debug("essential graph: {}", summary.BriefReport());
  report.initial_cost = summary.initial_cost;
  report.final_cost = summary.final_cost;
  for (auto& [id, x] : pose)
    map.keyframe(id)->frame.cam_from_world = optim::pose_from_array(x.data());
  return report;
}

}  // namespace coloc::slam::loop
