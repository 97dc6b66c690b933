#pragma once
// Pictures of a camera image against the scan rendered at its pose (the paper's Figures 5 and
// 10-12), shared by `coloc register --report` and `coloc eval table2`.
#include <filesystem>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "registration/align/scan_match.hpp"
#include "slam/core/camera.hpp"

namespace coloc::cli {

// The colour image of a TUM-layout sequence (rgb.txt) whose timestamp is within 1 ms of
// `timestamp`, undistorted to the ideal pinhole `ideal` through `camera` (BGR). nullopt when the
// sequence has no such image.
std::optional<cv::Mat> sequence_image(const std::filesystem::path& sequence, double timestamp,
                                      const Camera& camera, const PinholeCamera& ideal);

// The rendering (RGB), blended half and half with `image` (BGR) when it is not empty, with each
// correspondence drawn: a line from the image feature to the rendered feature, green for the
// inliers, red for the others. BGR.
cv::Mat scan_figure(const cv::Mat& rendering_rgb, const cv::Mat& image_bgr,
                    const std::vector<registration::align::ScanCorrespondence>& matches,
                    const std::string& caption);

// Writes a PNG through a temporary file renamed over `path`; throws coloc::Error naming it.
void write_png(const std::filesystem::path& path, const cv::Mat& image);

}  // namespace coloc::cli
