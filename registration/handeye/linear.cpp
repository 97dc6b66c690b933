#include "registration/handeye/linear.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>

#include "registration/handeye/compose.hpp"

namespace coloc::registration::handeye {

namespace {

double degrees(double radians) {
  return radians * 180.0 / std::numbers::pi;
}

struct PairCheck {
  bool bad = false;    // rotation angles of A and B disagree
  bool small = false;  // rotated too little to define an axis
};

PairCheck check_pair(const MotionPair& pair, const Options& options) {
  const double angle_a = pair.a.so3().angle();
  const double angle_b = pair.b.so3().angle();
  PairCheck check;
  check.bad = std::abs(angle_a - angle_b) > options.max_angle_mismatch;
  check.small = 0.5 * (angle_a + angle_b) < options.min_pair_rotation;
  return check;
}

// All pairs i < j; drops, one at a time, the registration with the largest fraction of
// inconsistent pairs while that fraction exceeds the option (a single bad registration makes
// all its pairs fail, while a good one fails only its pairs with bad registrations).
std::vector<MotionPair> build_all_pairs(std::span<const Registration> registrations,
                                        std::vector<bool>& used, const Options& options,
                                        Conditioning& conditioning) {
  const int n = static_cast<int>(registrations.size());
  std::vector<MotionPair> pairs;
  std::vector<PairCheck> checks;
  for (int i = 0; i < n; ++i) {
    if (!used[i]) continue;
    for (int j = i + 1; j < n; ++j) {
      if (!used[j]) continue;
      pairs.push_back(make_motion_pair(registrations[i], registrations[j], options.target));
      pairs.back().i = i;
      pairs.back().j = j;
      checks.push_back(check_pair(pairs.back(), options));
    }
  }
  for (;;) {
    std::vector<int> bad(n, 0);
    std::vector<int> total(n, 0);
    for (std::size_t k = 0; k < pairs.size(); ++k) {
      const auto [i, j] = std::pair{pairs[k].i, pairs[k].j};
      if (!used[i] || !used[j]) continue;
      ++total[i];
      ++total[j];
      if (checks[k].bad) {
        ++bad[i];
        ++bad[j];
      }
    }
    int worst = -1;
    double worst_fraction = options.max_bad_pair_fraction;
    for (int i = 0; i < n; ++i) {
      if (!used[i] || total[i] == 0) continue;
      const double fraction = static_cast<double>(bad[i]) / total[i];
      if (fraction > worst_fraction) {
        worst_fraction = fraction;
        worst = i;
      }
    }
    if (worst < 0) break;
    used[worst] = false;
  }
  std::vector<MotionPair> kept;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    if (checks[k].bad) {
      ++conditioning.pairs_rejected;  // counted even when a dropped registration explains it
      continue;
    }
    if (!used[pairs[k].i] || !used[pairs[k].j]) continue;
    if (checks[k].small) {
      ++conditioning.pairs_small;
    } else {
      kept.push_back(pairs[k]);
    }
  }
  return kept;
}

// Consecutive pairs; as in the paper, registration j is skipped when its pair with the last
// kept registration fails the angle test.
std::vector<MotionPair> build_consecutive_pairs(std::span<const Registration> registrations,
                                                std::vector<bool>& used, const Options& options,
                                                Conditioning& conditioning) {
  std::vector<MotionPair> kept;
  int last = -1;
  for (int j = 0; j < static_cast<int>(registrations.size()); ++j) {
    if (!used[j]) continue;
    if (last < 0) {
      last = j;
      continue;
    }
    MotionPair pair = make_motion_pair(registrations[last], registrations[j], options.target);
    pair.i = last;
    pair.j = j;
    const PairCheck check = check_pair(pair, options);
    if (check.bad) {
      ++conditioning.pairs_rejected;
      used[j] = false;
      continue;
    }
    if (check.small) {
      ++conditioning.pairs_small;
    } else {
      kept.push_back(pair);
    }
    last = j;
  }
  return kept;
}

}  // namespace

SE3 scaled(const SE3& camera_from_marker, double sigma) {
  return SE3(camera_from_marker.so3(), sigma * camera_from_marker.translation());
}

MotionPair make_motion_pair(const Registration& ri, const Registration& rj, Target target) {
  MotionPair pair;
  if (target == Target::kDeviceFromMarker) {
    pair.a = rj.vr_from_device.inverse() * ri.vr_from_device;          // device_j_from_device_i
    pair.b = rj.camera_from_marker.inverse() * ri.camera_from_marker;  // marker_j_from_marker_i
  } else {
    pair.a = rj.vr_from_device * ri.vr_from_device.inverse();
    pair.b = rj.camera_from_marker * ri.camera_from_marker.inverse();
  }
  return pair;
}

std::vector<MotionPair> build_pairs(std::span<const Registration> registrations,
                                    std::vector<bool>& used, const Options& options,
                                    Conditioning& conditioning) {
  conditioning.pairs_rejected = 0;
  conditioning.pairs_small = 0;
  if (options.pairs == PairMode::kAll) {
    return build_all_pairs(registrations, used, options, conditioning);
  }
  return build_consecutive_pairs(registrations, used, options, conditioning);
}

std::string advice(LinearStatus status, const Options& options) {
  std::ostringstream out;
  switch (status) {
    case LinearStatus::kOk:
      return "";
    case LinearStatus::kTooFewRegistrations:
      out << "fewer than 3 usable registrations (or fewer than 2 usable pairs): add "
             "registrations, rotating the controller about a different axis between them";
      break;
    case LinearStatus::kTooSmallRotations:
      out << "the controller barely rotated between registrations: rotate it by at least "
          << degrees(options.min_pair_rotation) << " degrees between registrations";
      break;
    case LinearStatus::kSingleAxis:
      out << "all rotations between registrations are about one axis (spread below "
          << degrees(options.min_axis_spread)
          << " degrees): rotate the controller about a different axis";
      break;
    case LinearStatus::kTranslationSingular:
      out << "the translation is not determined: rotate the controller about a different axis";
      break;
  }
  return out.str();
}

LinearSolution solve_linear(std::span<const MotionPair> pairs, const Options& options,
                            Conditioning& conditioning) {
  LinearSolution solution;
  conditioning.pairs_used = static_cast<int>(pairs.size());
  if (pairs.size() < 2) {
    solution.status = conditioning.pairs_small > 0 ? LinearStatus::kTooSmallRotations
                                                   : LinearStatus::kTooFewRegistrations;
    return solution;
  }
  // Rotation: w_A = R_X w_B for every pair (paper, Lemma 1 and eq. 7).
  Eigen::Matrix3d m_transposed = Eigen::Matrix3d::Zero();  // sum w_A w_B^T = M^T
  Eigen::Matrix3d axis_scatter = Eigen::Matrix3d::Zero();
  conditioning.max_pair_rotation = 0.0;
  for (const MotionPair& pair : pairs) {
    const Eigen::Vector3d w_a = pair.a.so3().log();
    const Eigen::Vector3d w_b = pair.b.so3().log();
    m_transposed += w_a * w_b.transpose();
    const double angle = w_a.norm();
    conditioning.max_pair_rotation = std::max(conditioning.max_pair_rotation, angle);
    const Eigen::Vector3d axis = w_a / angle;
    axis_scatter += axis * axis.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> scatter(axis_scatter);
  const double l1 = scatter.eigenvalues()(2);
  const double l2 = std::max(0.0, scatter.eigenvalues()(1));
  conditioning.axis_spread = 2.0 * std::atan(std::sqrt(l2 / l1));
  if (conditioning.axis_spread < options.min_axis_spread) {
    solution.status = LinearStatus::kSingleAxis;
    return solution;
  }
  // The rotation maximizing tr(R^T M^T): SO3::from_matrix's SVD projection (the polar factor).
  const Eigen::Matrix3d r_x = SO3::from_matrix(m_transposed).matrix();

  // Translation (and sigma): (R_A - I) t_X - sigma R_X t_B = -t_A, via the normal equations.
  const int unknowns = options.estimate_scale ? 4 : 3;
  Eigen::Matrix4d normal = Eigen::Matrix4d::Zero();
  Eigen::Vector4d rhs = Eigen::Vector4d::Zero();
  Eigen::Matrix<double, 3, 4> rows;
  for (const MotionPair& pair : pairs) {
    rows.leftCols<3>() = pair.a.rotation() - Eigen::Matrix3d::Identity();
    rows.col(3) = -(r_x * pair.b.translation());
    Eigen::Vector3d b = -pair.a.translation();
    if (!options.estimate_scale) b -= rows.col(3);  // sigma = 1 moves to the right-hand side
    normal.noalias() += rows.transpose() * rows;
    rhs.noalias() += rows.transpose() * b;
  }
  const Eigen::MatrixXd n = normal.topLeftCorner(unknowns, unknowns);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> normal_eigen(n);
  const double smallest = std::max(0.0, normal_eigen.eigenvalues()(0));
  const double largest = normal_eigen.eigenvalues()(unknowns - 1);
  conditioning.translation_min_singular_value = std::sqrt(smallest);
  if (!(smallest > 1e-12 * largest)) {
    solution.status = LinearStatus::kTranslationSingular;
    return solution;
  }
  const Eigen::VectorXd x = n.ldlt().solve(rhs.head(unknowns));
  solution.x = SE3(SO3::from_matrix(r_x), x.head<3>());
  solution.sigma = options.estimate_scale ? x(3) : 1.0;
  return solution;
}

SE3 other_unknown(std::span<const Registration> registrations, const std::vector<bool>& used,
                  const SE3& x, double sigma, Target target) {
  std::vector<SE3> poses;
  poses.reserve(registrations.size());
  for (std::size_t k = 0; k < registrations.size(); ++k) {
    if (!used[k]) continue;
    const Registration& r = registrations[k];
    const SE3 camera_from_marker = scaled(r.camera_from_marker, sigma);
    if (target == Target::kDeviceFromMarker) {
      poses.push_back(r.vr_from_device * x * camera_from_marker.inverse());
    } else {
      poses.push_back(r.vr_from_device.inverse() * x * camera_from_marker);
    }
  }
  return chordal_mean(poses);
}

}  // namespace coloc::registration::handeye
