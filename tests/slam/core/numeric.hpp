#pragma once
// Central-difference numerical derivatives for checking analytic Jacobians.

#include <Eigen/Core>

namespace coloc::testing {

// J(i, j) = d f_i / d x_j at x, by central differences with step h.
template <int Rows, int Cols, typename F>
Eigen::Matrix<double, Rows, Cols> numeric_jacobian(F&& f, const Eigen::Matrix<double, Cols, 1>& x,
                                                   double h = 1e-6) {
  Eigen::Matrix<double, Rows, Cols> j;
  for (int c = 0; c < Cols; ++c) {
    Eigen::Matrix<double, Cols, 1> xp = x;
    Eigen::Matrix<double, Cols, 1> xm = x;
    xp(c) += h;
    xm(c) -= h;
    j.col(c) = (f(xp) - f(xm)) / (2.0 * h);
  }
  return j;
}

}  // namespace coloc::testing
