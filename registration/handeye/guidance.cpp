#include "registration/handeye/guidance.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>
#include <vector>

#include "registration/handeye/linear.hpp"

namespace coloc::registration::handeye {

namespace {

constexpr double kEpsilon = 1e-4;  // keeps log det finite while rank deficient

using Matrix6 = Eigen::Matrix<double, 6, 6>;

Matrix6 pair_information(const Registration& ri, const Registration& rj) {
  const SE3 a = make_motion_pair(ri, rj, Target::kDeviceFromMarker).a;
  const Eigen::Vector3d w = a.so3().log();
  const double theta = w.norm();
  Matrix6 h = Matrix6::Zero();
  if (theta > 1e-12) {
    const Eigen::Vector3d axis = w / theta;
    h.topLeftCorner<3, 3>() =
        theta * theta * (Eigen::Matrix3d::Identity() - axis * axis.transpose());
  }
  const Eigen::Matrix3d m = a.rotation() - Eigen::Matrix3d::Identity();
  h.bottomRightCorner<3, 3>() = m.transpose() * m;
  return h;
}

Matrix6 information(std::span<const Registration> registrations) {
  Matrix6 h = Matrix6::Zero();
  for (std::size_t i = 0; i < registrations.size(); ++i) {
    for (std::size_t j = i + 1; j < registrations.size(); ++j) {
      h += pair_information(registrations[i], registrations[j]);
    }
  }
  return h;
}

double logdet(const Matrix6& h) {
  const Eigen::SelfAdjointEigenSolver<Matrix6> eigen(h + kEpsilon * Matrix6::Identity());
  return eigen.eigenvalues().array().log().sum();
}

std::string axis_text(const Eigen::Vector3d& axis) {
  std::ostringstream out;
  out.precision(2);
  out << std::fixed << "(" << axis.x() << ", " << axis.y() << ", " << axis.z() << ")";
  return out.str();
}

}  // namespace

SessionStatus session_status(std::span<const Registration> registrations, const Options& options) {
  SessionStatus status;
  status.registrations = static_cast<int>(registrations.size());
  const Matrix6 h = information(registrations);
  status.information_logdet = logdet(h);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> rotation(h.topLeftCorner<3, 3>());
  status.weakest_axis = rotation.eigenvectors().col(0);
  std::ostringstream advice;
  if (registrations.size() < 3) {
    advice << "register " << 3 - registrations.size()
           << " more time(s), rotating the controller between registrations";
    if (!registrations.empty())
      advice << " (e.g. about its axis " << axis_text(status.weakest_axis) << ")";
    status.advice = advice.str();
    return status;
  }
  Options relaxed = options;
  relaxed.estimate_scale = false;
  std::vector<bool> used(registrations.size(), true);
  Conditioning conditioning;
  const std::vector<MotionPair> pairs = build_pairs(registrations, used, relaxed, conditioning);
  const LinearSolution linear = solve_linear(pairs, relaxed, conditioning);
  status.axis_spread = conditioning.axis_spread;
  status.solvable = linear.status == LinearStatus::kOk;
  if (!status.solvable) {
    advice << handeye::advice(linear.status, options)
           << "; next, rotate the controller about its axis " << axis_text(status.weakest_axis)
           << " (device frame)";
  } else {
    advice << "solvable; more registrations help most when rotated about the controller's axis "
           << axis_text(status.weakest_axis) << " (device frame)";
  }
  status.advice = advice.str();
  return status;
}

NextRegistrationAdvice assess_next_registration(std::span<const Registration> so_far,
                                                const Registration& candidate,
                                                const Options& options, double min_gain) {
  NextRegistrationAdvice out;
  out.nearest_rotation = std::numeric_limits<double>::infinity();
  int bad = 0;
  Matrix6 added = Matrix6::Zero();
  for (const Registration& r : so_far) {
    const MotionPair pair = make_motion_pair(r, candidate, Target::kDeviceFromMarker);
    const double angle_a = pair.a.so3().angle();
    out.nearest_rotation = std::min(out.nearest_rotation, angle_a);
    if (std::abs(angle_a - pair.b.so3().angle()) > options.max_angle_mismatch) ++bad;
    added += pair_information(r, candidate);
  }
  if (so_far.empty()) out.nearest_rotation = 0.0;
  const Matrix6 before = information(so_far);
  out.information_gain = logdet(before + added) - logdet(before);
  out.consistent = so_far.empty() || bad <= options.max_bad_pair_fraction * so_far.size();
  const double degrees = 180.0 / std::numbers::pi;
  std::ostringstream advice;
  if (!out.consistent) {
    advice << "the marker pose disagrees with the controller pose (rotation angles differ in "
           << bad << " of " << so_far.size()
           << " pairs): check the marker detection and the time sync, then register again";
  } else if (!so_far.empty() && out.nearest_rotation < options.min_pair_rotation) {
    advice << "too close to an earlier registration (" << out.nearest_rotation * degrees
           << " degrees): rotate the controller by at least " << options.min_pair_rotation * degrees
           << " degrees first";
  } else if (out.information_gain < min_gain) {
    advice << "adds little information (" << out.information_gain
           << " nats): rotate about a different axis";
  } else {
    out.adds_information = true;
    advice << "adds information (" << out.information_gain << " nats): keep it";
  }
  out.advice = advice.str();
  return out;
}

}  // namespace coloc::registration::handeye
