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

// A station's geometry; its points and images go to a ScanSink as they are made.
struct ScanStation {
  int index = 0;
  SE3 world_from_station;
  std::array<SE3, 6> world_from_face;
  PinholeCamera face_camera;
};

// A batch of scan points: station frame, metres, with their RGB colours.
struct ScanPoints {
  std::vector<Eigen::Vector3d> xyz;
  std::vector<std::array<std::uint8_t, 3>> rgb;
  std::size_t size() const { return xyz.size(); }
  void clear() {
    xyz.clear();
    rgb.clear();
  }
};

// Receives a station while scan_station makes it: begin_station, then per cube face its points
// in batches of at most kScanBatch and its image, then end_station. So a scan of a billion
// points never exists in memory, not even one station's or one face's points.
class ScanSink {
 public:
  virtual ~ScanSink() = default;
  virtual void begin_station(const ScanStation& station) = 0;
  // Points in the station's order (face by face, rows top to bottom); valid during the call.
  virtual void add_points(const ScanPoints& points) = 0;
  // Face f's image (CV_8UC3, RGB), after that face's points; valid during the call.
  virtual void add_face(std::size_t f, const cv::Mat& colour) = 0;
  virtual void end_station() = 0;
};

inline constexpr std::size_t kScanBatch = 65536;  // points per ScanSink::add_points at most

// Renders the station's faces with `renderer` (which must hold the scene mesh), samples their
// points and hands both to `sink`. Deterministic in (inputs, seed); the batches do not change
// the points. Returns the station's geometry.
ScanStation scan_station(render::Renderer& renderer, int index, const SE3& world_from_station,
                         const ScanOptions& options, std::uint64_t seed, ScanSink& sink);

// A sink that keeps what it receives (tests, `coloc bench render`): memory grows with the
// points, so for small scans only.
class ScanCollector : public ScanSink {
 public:
  void begin_station(const ScanStation& station) override { stations.push_back(station); }
  void add_points(const ScanPoints& batch) override {
    points.xyz.insert(points.xyz.end(), batch.xyz.begin(), batch.xyz.end());
    points.rgb.insert(points.rgb.end(), batch.rgb.begin(), batch.rgb.end());
  }
  void add_face(std::size_t f, const cv::Mat& colour) override { faces[f] = colour.clone(); }
  void end_station() override {}

  std::vector<ScanStation> stations;
  ScanPoints points;             // all stations' points, each in its station's frame
  std::array<cv::Mat, 6> faces;  // the last station's faces
};

// Streams stations into one E57 file (points in each station's frame with its pose, six pinhole
// images per station with their poses) and a binary PLY of all points in the world frame. Holds
// one batch of points and the station's six encoded JPEGs (E57 takes images only between
// scans), so its memory does not grow with the points.
class ScanFileWriter : public ScanSink {
 public:
  ScanFileWriter(const std::filesystem::path& e57_path, const std::filesystem::path& ply_path,
                 std::uint64_t seed, int jpeg_quality);
  ~ScanFileWriter() override;
  ScanFileWriter(const ScanFileWriter&) = delete;
  ScanFileWriter& operator=(const ScanFileWriter&) = delete;

  void begin_station(const ScanStation& station) override;
  void add_points(const ScanPoints& points) override;
  void add_face(std::size_t f, const cv::Mat& colour) override;
  void end_station() override;
  // Finishes both files; returns the number of points written.
  std::size_t close();

 private:
  void flush_e57(std::size_t count);
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace coloc::registration::twin
