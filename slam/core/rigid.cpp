#include "slam/core/rigid.hpp"

#include <cmath>
#include <sstream>

namespace coloc {

std::optional<std::string> rigid_problem(const Eigen::Matrix4d& m, double tolerance) {
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      if (!std::isfinite(m(r, c)))
        return "non-finite number at row " + std::to_string(r + 1) + ", column " +
               std::to_string(c + 1);
  std::ostringstream why;
  why.precision(3);
  const Eigen::Matrix3d rotation = m.topLeftCorner<3, 3>();
  const double orthonormal =
      (rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (orthonormal > tolerance) {
    why << "rotation not orthonormal (scaled or sheared: max |R^T R - I| = " << orthonormal
        << ", tolerance " << tolerance << ")";
    return why.str();
  }
  const double det = rotation.determinant();
  if (std::abs(det - 1.0) > tolerance) {
    why << "rotation has determinant " << det << ", not +1 (a reflection?)";
    return why.str();
  }
  const double last_row = (m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff();
  if (last_row > tolerance) {
    why << "last row is " << m(3, 0) << " " << m(3, 1) << " " << m(3, 2) << " " << m(3, 3)
        << ", not 0 0 0 1";
    return why.str();
  }
  return std::nullopt;
}

SE3 rigid_from_matrix(const Eigen::Matrix4d& m, const ErrorContext& where, double tolerance) {
  if (const auto problem = rigid_problem(m, tolerance))
    throw Error("not a rigid transform: " + *problem, where);
  return SE3::from_matrix(m);
}

SE3 rigid_from_quaternion(const Eigen::Vector3d& t, const Eigen::Vector4d& xyzw,
                          const ErrorContext& where, double tolerance) {
  if (!t.allFinite() || !xyzw.allFinite())
    throw Error("not a rigid transform: non-finite number", where);
  if (std::abs(xyzw.norm() - 1.0) > tolerance) {
    std::ostringstream why;
    why.precision(6);
    why << "not a rigid transform: quaternion norm " << xyzw.norm() << ", not 1";
    throw Error(why.str(), where);
  }
  const Eigen::Quaterniond q(xyzw[3], xyzw[0], xyzw[1], xyzw[2]);
  return SE3(q.normalized(), t);
}

bool finite_pose(const SE3& pose) {
  return pose.translation().allFinite() && pose.quaternion().coeffs().allFinite();
}

}  // namespace coloc
