#pragma once
// Camera intrinsics from photos of a chessboard or a ChArUco board (OpenCV's detectors and
// calibrateCamera): `coloc calibrate`, useful for any camera and the fallback when a D4xx's
// factory tables cannot be read. Every image is accounted for: its reprojection error, or why
// it was left out (no board found, too few corners, or the same view as an earlier image, which
// adds nothing to the estimate).
#include <filesystem>
#include <string>
#include <vector>

#include "slam/core/camera.hpp"

namespace coloc::capture {

struct CalibrateOptions {
  enum class Target { kChessboard, kCharuco };
  Target target = Target::kChessboard;
  int cols = 0, rows = 0;  // chessboard: inner corners; ChArUco: squares
  double square = 0.0;     // metres
  double marker = 0.0;     // ChArUco marker side, metres
  std::string dictionary = "DICT_6X6_250";
  // Two views closer than this (board rotation, and translation relative to distance) count
  // as the same view.
  double same_view_deg = 1.0;
  double same_view_rel = 0.01;
  void check() const;  // throws coloc::Error naming the field
};

struct ImageReport {
  std::filesystem::path path;
  bool used = false;
  std::size_t corners = 0;
  double rms_px = 0.0;  // per-image reprojection error (used images)
  std::string note;     // why it was left out
};

struct CameraCalibration {
  PinholeCamera camera;
  double rms_px = 0.0;
  std::vector<ImageReport> images;
  std::size_t used() const;
};

// Throws coloc::Error naming the image that cannot be read, or saying that fewer than 3 images
// showed the board (with every image's reason).
CameraCalibration calibrate_camera(const std::vector<std::filesystem::path>& images,
                                   const CalibrateOptions& options);

}  // namespace coloc::capture
