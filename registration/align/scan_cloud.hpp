#pragma once
// The laser scan as the renderer draws it for the point-cloud refinement (Michiels et al. 2024,
// section 4.5), from an E57 file or a PLY / PCD export: every scan of an E57 file moved into the
// file's frame (world_from_scan), its
// colour (or intensity as grey) normalized to 8 bits, and thinned by a voxel grid so a keyframe
// renders in a fraction of a second while its surfaces stay closed.
//
// Downsampling: one point per occupied voxel of side `voxel_size` (metres), at the mean
// position and colour of the voxel's points, as PCL's VoxelGrid does, but over the points of the
// stations that sampled the voxel finest only (below), which VoxelGrid cannot express; so this
// is our own voxel key. The grid is built while the file is read, piece by piece
// (voxel_grid.hpp), so the scan's memory grows with the occupied voxels (~90 bytes each), not
// with the points: a 200-million-point site scan is never held whole. Deterministic: the same
// file and options give the same cloud, voxels in ascending key order, whatever the piece size.
// voxel_size 0 keeps every point, so that cloud is as large as the file.
// Then stray points are removed (scan_outliers.hpp, PCL's k-d tree).
//
// Splats: a scan samples its surroundings at a fixed angular step, so its points are farther
// apart far from the station: a point's spacing is range * the scan's angular step, estimated
// as sqrt(4 pi / points of the scan) (a full-sphere scan; a scan with a smaller field of view
// gets larger splats, which only blurs). Each point is drawn as a square of
// max(splat_factor * voxel_size, range_splat_factor * spacing) metres, so the rendering has no
// holes; the renderer's depth test keeps the nearest surface, so what is hidden in the photo is
// hidden in the rendering. Where stations overlap, a voxel keeps the points of the stations
// that sampled it finest (spacing within 1.5x of the finest), so a far station's coarse points
// do not blur a near one's.
#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <vector>

#include "registration/align/scan_outliers.hpp"
#include "registration/render/scene.hpp"

namespace coloc::registration::align {

struct ScanCloudOptions {
  double voxel_size = 0.01;         // metres; 0 keeps every point
  double splat_factor = 1.6;        // splat side / voxel_size (>= 1 closes the surfaces)
  double range_splat_factor = 1.5;  // splat side / the point's spacing (0: voxel size only)
  float max_splat_pixels = 24.0f;
  // Points farther than this from their scanner are dropped (metres; 0 = no limit): far points
  // are sparse and noisy, and a keyframe sees them better from another station.
  double max_range = 0.0;
  StrayPointOptions stray;
  // Points read from the file per piece: bounds the reading buffers only; the cloud does not
  // depend on it (tests force it small).
  std::size_t chunk_points = std::size_t{1} << 16;
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

struct ScanCloudStats {
  std::uint64_t scans = 0, points_read = 0, points_kept = 0;
  std::uint64_t points_stray = 0;  // removed as stray after the voxel grid
  bool colour = false;             // colour fields were used (else intensity, else mid grey)
  double ms = 0.0;
};

// A piece of a scan as load_scan_cloud reads it: valid points within max_range in the file's
// frame (metres), colours normalized to 8 bits, and for the stations of an E57 file each point's
// spacing (range * the scan's angular step, metres); spacings is empty for a PLY / PCD file.
struct ScanPiece {
  std::vector<Eigen::Vector3f> points;
  std::vector<std::array<std::uint8_t, 3>> colours;
  std::vector<float> spacings;
};

// Reads every point of a scan file in file order, in pieces of at most options.chunk_points
// records, and hands each piece to `sink`; sets stats' scans, points_read and colour. Throws as
// load_scan_cloud does (but not for a file without valid points). load_scan_cloud's reader,
// for tests and tools that need the points themselves.
void read_scan_pieces(const std::filesystem::path& path, const ScanCloudOptions& options,
                      const std::function<void(const ScanPiece&)>& sink,
                      ScanCloudStats* stats = nullptr,
                      const std::function<void(std::uint64_t, std::uint64_t)>& progress = {});

// Reads a scan: E57 (every scan with cartesian coordinates), or a PLY or PCD cloud
// (point_file.hpp), told by the file's content. Throws coloc::Error (naming the file) when it
// cannot be read, has no scan with cartesian coordinates, or holds no valid point. `progress`
// (may be empty) is called with (points read, points in the file).
render::PointCloud load_scan_cloud(
    const std::filesystem::path& path, const ScanCloudOptions& options = {},
    ScanCloudStats* stats = nullptr,
    const std::function<void(std::uint64_t, std::uint64_t)>& progress = {});

// The voxel-grid filter alone, on a cloud in memory (points with colours, and in splat_sizes,
// when not empty, each point's spacing in metres); returns the thinned cloud with its splat
// sizes set as above. The batch form of load_scan_cloud's grid: on the same points in the same
// order both give the same cloud (positions within float rounding).
render::PointCloud voxel_downsample(const render::PointCloud& cloud,
                                    const ScanCloudOptions& options);

}  // namespace coloc::registration::align
