#pragma once
// A 4x4 transform stored as an OpenCV `!!opencv-matrix` node (ORB-SLAM3's IMU.T_b_c1, a camera
// calibration's color_from_depth, `--cam-from-head`). Decoding the node with `>> cv::Mat`
// allocates rows x cols x the element size first, whatever the numbers say: a fuzzed `rows`
// of 2^32 asked for 64 GiB (scripts/fuzz_yaml). So the shape is checked on the node before
// anything is decoded, and every reader of such a matrix goes through here.
#include <opencv2/core/persistence.hpp>
#include <optional>

#include "slam/core/error.hpp"
#include "slam/core/se3.hpp"

namespace coloc::settings {

// Empty when the node is absent. Otherwise the transform, or a coloc::Error with `where` (file and
// key) saying what is wrong: not an opencv-matrix, not 4x4, not numbers, not a rigid transform
// (slam/core's rigid check: finite, orthonormal rotation, last row 0 0 0 1).
std::optional<SE3> read_rigid_matrix(const cv::FileNode& node, const ErrorContext& where);

}  // namespace coloc::settings
