#pragma once
// Point clouds in the formats users export their scans in, besides E57 (e57io): PLY (ASCII,
// binary little- or big-endian; CloudCompare, Cyclone, Open3D, PCL, MeshLab) and PCL's PCD
// (ascii, binary, binary_compressed). The format is told by the file's first bytes, never by its
// name. Points stream out in batches, so a file larger than memory can be thinned as it is read.
//
// What is read: the vertex positions (x, y, z in any numeric type; metres, the file's frame) and
// the colour when the file has one (PLY red/green/blue or diffuse_*, PCD rgb / rgba packed as
// PCL packs them), 8 bits a channel. Other properties (normals, intensity, faces) are skipped.
// Points with a non-finite coordinate (PCL's organized clouds mark holes so) are dropped and
// counted. PCD's VIEWPOINT is not applied, as PCL's own tools do not apply it.
//
// Bad files are coloc::Error naming the file and the header field, line or byte offset.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

namespace coloc::registration::align {

enum class PointFileFormat : std::uint8_t { kE57, kPly, kPcd };
const char* format_name(PointFileFormat format);

// By content: "ASTM-E57" (E57's file header), "ply" (PLY), or a PCD header ("# .PCD" comment
// or a VERSION / FIELDS line first). Throws coloc::Error naming the file otherwise.
PointFileFormat detect_point_file(const std::filesystem::path& path);

struct PointBatch {
  std::vector<Eigen::Vector3f> points;
  std::vector<std::array<std::uint8_t, 3>> colours;  // RGB, one per point; empty without colour
  void clear() {
    points.clear();
    colours.clear();
  }
};

// A PLY or PCD file, opened and its header checked at construction.
class PointFileReader {
 public:
  explicit PointFileReader(const std::filesystem::path& path);
  ~PointFileReader();
  PointFileReader(const PointFileReader&) = delete;
  PointFileReader& operator=(const PointFileReader&) = delete;

  PointFileFormat format() const;
  std::uint64_t points_declared() const;  // the header's count (holes included)
  bool has_colour() const;
  std::uint64_t dropped() const;  // points with a non-finite coordinate, so far

  // Appends up to `max` points to `batch` (cleared first); returns how many records were
  // consumed (0 at the end). Throws coloc::Error at a record that cannot be read.
  std::size_t read(PointBatch& batch, std::size_t max);

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace coloc::registration::align
