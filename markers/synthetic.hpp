#pragma once
// Synthetic marker images with exactly known geometry, for tests, benchmarks and the synthetic
// twin: a marker is rendered by casting rays through each pixel (supersampled) onto the marker
// plane, so any camera model of slam/core works and corner positions are exact up to the
// anti-aliasing of the supersampling.

#include <functional>
#include <opencv2/aruco/dictionary.hpp>
#include <opencv2/core/mat.hpp>

#include "slam/core/camera.hpp"
#include "slam/core/se3.hpp"

namespace coloc::markers {

struct RenderOptions {
  int supersample = 4;          // samples per pixel along each axis
  double quiet_zone_cells = 1;  // white margin around the black border, in marker cells
  unsigned char black = 20;
  unsigned char white = 235;
};

// Draws marker `id` of `dictionary` (edge length `marker_size` metres, marker frame as in
// marker_pose.hpp) seen under `camera_from_marker` into `image` (8-bit, 1 channel, the camera's
// size), blending with what is there at the edges. Only the marker's bounding box is touched.
// Throws coloc::Error for a wrong image type or size.
void render_marker(cv::Mat& image, const Camera& camera, const SE3& camera_from_marker,
                   const cv::aruco::Dictionary& dictionary, int id, double marker_size,
                   const RenderOptions& options = {});

// The general form, for image models that are not a coloc::Camera (spherical panoramas):
// `bearing(pixel)` gives the ray of a pixel in the camera frame (any length, or NaN for pixels
// outside the model); only pixels inside `box` are drawn.
using BearingFunction = std::function<Eigen::Vector3d(const Eigen::Vector2d& pixel)>;
void render_marker_rays(cv::Mat& image, const cv::Rect& box, const BearingFunction& bearing,
                        const SE3& camera_from_marker, const cv::aruco::Dictionary& dictionary,
                        int id, double marker_size, const RenderOptions& options = {});

}  // namespace coloc::markers
