#include "slam/settings/opencv_matrix.hpp"

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>

#include "slam/core/rigid.hpp"

namespace coloc::settings {

std::optional<SE3> read_rigid_matrix(const cv::FileNode& node, const ErrorContext& where) {
  if (node.empty()) return std::nullopt;
  const auto fail = [&](const std::string& what) {
    throw Error("expected a 4x4 !!opencv-matrix: " + what, where);
  };
  if (!node.isMap()) fail("not a matrix node");
  const cv::FileNode rows = node["rows"];
  const cv::FileNode cols = node["cols"];
  if (!rows.isInt() || !cols.isInt()) fail("rows and cols must be integers");
  if (static_cast<int>(rows) != 4 || static_cast<int>(cols) != 4) {
    fail("got " + std::to_string(static_cast<int>(rows)) + "x" +
         std::to_string(static_cast<int>(cols)));
  }
  cv::Mat m;
  try {
    node >> m;
  } catch (const cv::Exception& e) {
    fail(e.err);
  }
  if (m.rows != 4 || m.cols != 4 || m.channels() != 1) fail("not 16 numbers");
  m.convertTo(m, CV_64F);
  Eigen::Matrix4d t;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      t(r, c) = m.at<double>(r, c);
  return rigid_from_matrix(t, where);
}

}  // namespace coloc::settings
