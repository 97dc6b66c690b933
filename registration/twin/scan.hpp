#pragma once
// The twin's terrestrial laser scan: at each station, six 90-degree cube-face images are rendered
// (the scanner's camera) and the scan points are the surface points behind a regular subset of
// their pixels (so points and images agree exactly), with range noise along each ray.
//
// Frames: station: z up, level, arbitrary heading; world_from_station places it in the world
// (= scan) frame. Face cameras use coloc's convention (x right, y down, z forward), pixel centres
// at integer coordinates; world_from_face = world_from_station * station_from_face.

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "registration/render/renderer.hpp"
#include "slam/core/se3.hpp"

namespace coloc::registration::twin {

struct ScanOptions {
  int face_size = 2048;        // pixels per cube-face side
  int point_step = 8;          // one scan point every point_step face pixels (each direction)
  double range_noise = 0.002;  // metres, standard deviation along the ray
  double max_range = 40.0;     // metres
  int jpeg_quality = 92;

  void check() const;
};

struct ScanStation {
  int index = 0;
  SE3 world_from_station;
  std::vector<Eigen::Vector3d> points;               // station frame, metres
  std::vector<std::array<std::uint8_t, 3>> colours;  // RGB
  std::array<cv::Mat, 6> faces;                      // CV_8UC3, RGB
  std::array<SE3, 6> world_from_face;
  PinholeCamera face_camera;
};

// Renders the station's faces with `renderer` (which must hold the scene mesh) and samples its
// points. Deterministic in (inputs, seed).
ScanStation scan_station(render::Renderer& renderer, int index, const SE3& world_from_station,
                         const ScanOptions& options, std::uint64_t seed);

// Streams stations into one E57 file (points in each station's frame with its pose, six pinhole
// images per station with their poses) and a binary PLY of all points in the world frame.
class ScanFileWriter {
 public:
  ScanFileWriter(const std::filesystem::path& e57_path, const std::filesystem::path& ply_path,
                 std::uint64_t seed, int jpeg_quality);
  ~ScanFileWriter();
  ScanFileWriter(const ScanFileWriter&) = delete;
  ScanFileWriter& operator=(const ScanFileWriter&) = delete;

  void add(const ScanStation& station);
  // Finishes both files; returns the number of points written.
  std::size_t close();

 private:
  void add_e57(const ScanStation& station);
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace coloc::registration::twin
