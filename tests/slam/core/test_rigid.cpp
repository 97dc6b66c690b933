// The one rigid-transform check every reader of a 4x4 or pose uses: rotations pass, scale,
// shear, reflection, a bad last row and NaN fail with the file and field named.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "slam/core/rigid.hpp"

namespace coloc {
namespace {

Eigen::Matrix4d turned() {
  return SE3(SO3::exp(Eigen::Vector3d(0.3, -0.2, 1.1)), Eigen::Vector3d(1, 2, 3)).matrix();
}

std::string problem_of(const Eigen::Matrix4d& m) {
  try {
    rigid_from_matrix(m, {.file = "cal.yaml", .field = "vr_from_camera"});
  } catch (const Error& e) {
    EXPECT_EQ(e.context().file, "cal.yaml");
    EXPECT_EQ(e.context().field, "vr_from_camera");
    return e.message();
  }
  return "";
}

TEST(Rigid, RotationsPassWithinTheStatedTolerance) {
  EXPECT_FALSE(rigid_problem(turned()).has_value());
  Eigen::Matrix4d rounded = turned();
  for (int k = 0; k < 16; ++k)  // written with 6 decimals
    rounded(k / 4, k % 4) = std::round(rounded(k / 4, k % 4) * 1e6) / 1e6;
  EXPECT_FALSE(rigid_problem(rounded).has_value());
  EXPECT_LT(translation_distance(rigid_from_matrix(rounded, {}), SE3::from_matrix(turned())), 1e-5);
}

TEST(Rigid, ScaleShearReflectionLastRowAndNanAreRefusedAndNamed) {
  Eigen::Matrix4d m = turned();
  m.topLeftCorner<3, 3>() *= 1.01;
  EXPECT_NE(problem_of(m).find("not orthonormal"), std::string::npos);
  m = turned();
  m(0, 1) += 0.05;
  EXPECT_NE(problem_of(m).find("not orthonormal"), std::string::npos);
  m = turned();
  m.row(2) *= -1.0;
  EXPECT_NE(problem_of(m).find("determinant"), std::string::npos);
  m = turned();
  m(3, 0) = 0.1;
  EXPECT_NE(problem_of(m).find("last row"), std::string::npos);
  m = turned();
  m(3, 3) = 2.0;
  EXPECT_NE(problem_of(m).find("last row"), std::string::npos);
  m = turned();
  m(1, 2) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(problem_of(m).find("non-finite number at row 2, column 3"), std::string::npos);
  m = turned();
  m(0, 3) = std::numeric_limits<double>::infinity();
  EXPECT_NE(problem_of(m).find("non-finite"), std::string::npos);
}

TEST(Rigid, QuaternionPosesNeedFiniteNumbersAndAUnitQuaternion) {
  const ErrorContext where{.file = "session.yaml", .field = "anchor.world_from_camera"};
  const SE3 p = rigid_from_quaternion({1, 2, 3}, {0, 0, 0.7071068, 0.7071068}, where);
  EXPECT_NEAR(p.quaternion().norm(), 1.0, 1e-12);
  EXPECT_THROW(rigid_from_quaternion({1, 2, 3}, {0, 0, 0, 2}, where), Error);
  EXPECT_THROW(rigid_from_quaternion({std::nan(""), 2, 3}, {0, 0, 0, 1}, where), Error);
  EXPECT_THROW(rigid_from_quaternion({1, 2, 3}, {0, std::nan(""), 0, 1}, where), Error);
  EXPECT_TRUE(finite_pose(p));
  SE3 bad = p;
  bad.translation().x() = std::nan("");
  EXPECT_FALSE(finite_pose(bad));
}

}  // namespace
}  // namespace coloc
