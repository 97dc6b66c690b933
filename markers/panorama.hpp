#pragma once
// Panoramic scanner images (E57 sphericalRepresentation / cylindricalRepresentation) and their
// resampling into the six 90-degree pinhole faces of a cube map, where markers are detected
// (Michiels et al. 2024, section 4.3: cube faces of 2048 x 2048).
//
// Panorama frame: the image's own frame (E57 Image2D pose = global_from_image), z up, azimuth
// theta = atan2(y, x) counter-clockwise from +x, elevation phi from the xy plane. Pixel centres at
// integers. The mapping, stated once here:
//   column c = (pi - theta) / pixel_width - 0.5        (c = -0.5 at theta = +pi; azimuth
//                                                      decreases to the right, as a panorama
//                                                      seen from inside the sphere)
//   spherical:   row r = height / 2 - phi / pixel_height - 0.5   (horizon at the middle row)
//   cylindrical: row r = principal_point_y - radius * tan(phi) / pixel_height
// Face frames: camera x right, y down, z forward (as slam/core/camera.hpp); faces look along
// +x, -x, +y, -y (image down = -z), +z (image down = -x) and -z (image down = +x).

#include <Eigen/Core>
#include <array>
#include <opencv2/aruco/dictionary.hpp>
#include <opencv2/core/mat.hpp>

#include "markers/synthetic.hpp"
#include "slam/core/camera.hpp"
#include "slam/core/cube_map.hpp"
#include "slam/core/so3.hpp"

namespace coloc::markers {

enum class PanoramaKind { kSpherical, kCylindrical };

struct PanoramaModel {
  PanoramaKind kind = PanoramaKind::kSpherical;
  int width = 0, height = 0;     // pixels
  double pixel_width = 0.0;      // radians of azimuth per column
  double pixel_height = 0.0;     // spherical: radians per row; cylindrical: metres per row
  double radius = 0.0;           // cylindrical: metres
  double principal_point_y = 0;  // cylindrical: row of the horizon (pixels)

  // A full equirectangular panorama (2*pi by pi) of the given width (height = width / 2).
  static PanoramaModel equirectangular(int width);

  // Throws coloc::Error naming the first bad field.
  void check() const;
  // Unit direction (panorama frame) of a pixel; NaN outside the elevation range of the model.
  Eigen::Vector3d direction(const Eigen::Vector2d& pixel) const;
  // Pixel of a direction (any length); column in [-0.5, width - 0.5).
  Eigen::Vector2d pixel(const Eigen::Vector3d& direction) const;
};

// Cube faces (kCubeFaces, cube_face_name, cube_face_rotations = panorama_from_face,
// cube_face_camera): slam/core/cube_map.hpp, shared with the twin's scanner.

// Resamples one cube face (bilinear) from an 8-bit panorama (1 or 3 channels) described by
// `model`. Pixels whose direction falls outside the panorama are black. Throws coloc::Error when
// the image size differs from the model's.
cv::Mat resample_cube_face(const cv::Mat& panorama, const PanoramaModel& model, int face, int size);

// Draws a marker into a panorama (8-bit grey) seen under `panorama_from_marker`, for tests and
// synthetic scans. Not for markers straddling the azimuth seam (it then fills the whole width,
// correctly but slowly).
void render_marker_panorama(cv::Mat& panorama, const PanoramaModel& model,
                            const SE3& panorama_from_marker,
                            const cv::aruco::Dictionary& dictionary, int id, double marker_size,
                            const RenderOptions& options = {});

}  // namespace coloc::markers
