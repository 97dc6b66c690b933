#pragma once
// Least-squares alignment of corresponding 3-D point sets (Umeyama 1991 / Horn 1987):
// finds dst_from_src minimizing sum_i w_i |dst_i - (s R src_i + t)|^2, with s = 1 for SE3.

#include <Eigen/Core>
#include <vector>

#include "slam/core/sim3.hpp"

namespace coloc {

struct AlignmentOptions {
  bool estimate_scale = false;  // Sim3 (true) or SE3 (false)
  // Per-point non-negative weights; empty means all ones. Must match the point count.
  std::vector<double> weights;
};

struct AlignmentResult {
  Sim3 dst_from_src;  // scale is exactly 1 when estimate_scale is false
  double rmse = 0.0;  // weighted RMS of the residuals after alignment (metres)
  // Smallest-to-largest singular value ratio of the cross-covariance: near 0 when the points
  // are (nearly) collinear and the rotation about that line is undetermined.
  double conditioning = 0.0;
  bool usable = false;  // false for < 3 points, zero total weight or degenerate geometry
};

// Throws coloc::Error when the sizes of src, dst and weights differ.
AlignmentResult align_points(const std::vector<Eigen::Vector3d>& src,
                             const std::vector<Eigen::Vector3d>& dst,
                             const AlignmentOptions& options = {});

}  // namespace coloc
