#pragma once
// The one check of a rigid transform read from a file (a 4x4 matrix or a translation +
// quaternion): every reader of a calibration, a mounting, an anchor or an initial transform
// calls it, so a scaled, sheared or mirrored rotation, a bad last row or a NaN is an Error
// naming the file and the field instead of a participant silently moved or a NaN on the wire.
//
// Rigid means: every number finite; R^T R = I and det R = +1 (a rotation, not a reflection),
// each within kRigidTolerance; the last row 0 0 0 1 within kRigidTolerance. The tolerance
// admits matrices written with 6 significant digits (|R^T R - I| ~ 1e-6) and refuses any real
// scale or shear (a 0.1 % scale is 2e-3).
#include <Eigen/Core>
#include <optional>
#include <string>

#include "slam/core/error.hpp"
#include "slam/core/se3.hpp"

namespace coloc {

inline constexpr double kRigidTolerance = 1e-3;

// What makes `m` not rigid ("rotation not orthonormal (max |R^T R - I| = 0.02)", ...), or
// nothing when it is rigid.
std::optional<std::string> rigid_problem(const Eigen::Matrix4d& m,
                                         double tolerance = kRigidTolerance);

// The SE3 of a rigid `m`; throws coloc::Error with `where` (file, field) otherwise.
SE3 rigid_from_matrix(const Eigen::Matrix4d& m, const ErrorContext& where,
                      double tolerance = kRigidTolerance);

// The SE3 of a translation and a unit quaternion (x y z w); throws coloc::Error with `where`
// when a number is not finite or |q| is not 1 within the tolerance.
SE3 rigid_from_quaternion(const Eigen::Vector3d& t, const Eigen::Vector4d& xyzw,
                          const ErrorContext& where, double tolerance = kRigidTolerance);

// True when every number of `pose` is finite (what may be written or sent).
bool finite_pose(const SE3& pose);

}  // namespace coloc
