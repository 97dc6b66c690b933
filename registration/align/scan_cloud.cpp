#include "registration/align/scan_cloud.hpp"

#include <spdlog/spdlog.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>

#include "e57io/error.hpp"
#include "e57io/reader.hpp"
#include "registration/align/point_file.hpp"
#include "registration/align/voxel_grid.hpp"
#include "slam/core/error.hpp"
#include "slam/core/timing.hpp"

namespace coloc::registration::align {

namespace {

// The splat of a voxel (scan_cloud.hpp): the voxel's size, or range_splat_factor times the
// mean spacing of its points when larger.
float base_splat(const ScanCloudOptions& o) {
  return static_cast<float>(std::max(o.voxel_size, 0.005) * o.splat_factor);
}
float splat_of(const ScanCloudOptions& o, double spacing) {
  return static_cast<float>(
      std::max(static_cast<double>(base_splat(o)), o.range_splat_factor * spacing));
}

std::uint8_t to_byte(double v, double lo, double hi) {
  const double t = hi > lo ? (v - lo) / (hi - lo) : v / 255.0;
  return static_cast<std::uint8_t>(std::lround(std::clamp(t, 0.0, 1.0) * 255.0));
}

}  // namespace

void ScanCloudOptions::check() const {
  if (!(voxel_size >= 0.0)) throw Error("must be >= 0 (metres)", {.field = "voxel_size"});
  if (!(splat_factor >= 0.5)) throw Error("must be >= 0.5", {.field = "splat_factor"});
  if (!(range_splat_factor >= 0.0)) throw Error("must be >= 0", {.field = "range_splat_factor"});
  if (!(max_splat_pixels >= 1.0f)) throw Error("must be >= 1", {.field = "max_splat_pixels"});
  if (!(max_range >= 0.0)) throw Error("must be >= 0 (metres)", {.field = "max_range"});
  if (chunk_points < 1) throw Error("must be >= 1", {.field = "chunk_points"});
  stray.check();
}

render::PointCloud voxel_downsample(const render::PointCloud& cloud, const ScanCloudOptions& o) {
  o.check();
  render::PointCloud out;
  out.max_splat_pixels = o.max_splat_pixels;
  out.splat_size = base_splat(o);
  const bool spaced = !cloud.splat_sizes.empty() && o.range_splat_factor > 0.0;
  const auto splat = [&](double spacing) { return splat_of(o, spacing); };
  if (o.voxel_size <= 0.0) {
    out.points = cloud.points;
    out.colours = cloud.colours;
    if (spaced) {
      for (float sp : cloud.splat_sizes)
        out.splat_sizes.push_back(splat(sp));
    }
    return out;
  }
  const double inv = 1.0 / o.voxel_size;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keys(cloud.points.size());
  for (std::size_t i = 0; i < cloud.points.size(); ++i)
    keys[i] = {voxel_key(cloud.points[i], inv), static_cast<std::uint32_t>(i)};
  std::sort(keys.begin(), keys.end());
  for (std::size_t a = 0; a < keys.size();) {
    std::size_t b = a;
    double finest = 1e30;
    for (; b < keys.size() && keys[b].first == keys[a].first; ++b) {
      if (spaced) finest = std::min(finest, static_cast<double>(cloud.splat_sizes[keys[b].second]));
    }
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Vector3d rgb = Eigen::Vector3d::Zero();
    double spacing = 0.0;
    double n = 0.0;
    for (std::size_t k = a; k < b; ++k) {
      const std::uint32_t i = keys[k].second;
      if (spaced && cloud.splat_sizes[i] > 1.5 * finest) continue;
      sum += cloud.points[i].cast<double>();
      const auto& c = cloud.colours[i];
      rgb += Eigen::Vector3d(c[0], c[1], c[2]);
      if (spaced) spacing += cloud.splat_sizes[i];
      n += 1.0;
    }
    out.points.push_back((sum / n).cast<float>());
    rgb /= n;
    out.colours.push_back({static_cast<std::uint8_t>(std::lround(rgb.x())),
                           static_cast<std::uint8_t>(std::lround(rgb.y())),
                           static_cast<std::uint8_t>(std::lround(rgb.z()))});
    if (spaced) out.splat_sizes.push_back(splat(spacing / n));
    a = b;
  }
  return out;
}

namespace {

constexpr std::uint32_t kXyz = e57::field_bit(e57::PointField::kCartesianX) |
                               e57::field_bit(e57::PointField::kCartesianY) |
                               e57::field_bit(e57::PointField::kCartesianZ);
constexpr std::uint32_t kRgb = e57::field_bit(e57::PointField::kColorRed) |
                               e57::field_bit(e57::PointField::kColorGreen) |
                               e57::field_bit(e57::PointField::kColorBlue);

Eigen::Isometry3d world_from_scan_of(const e57::Data3D& d) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  if (d.pose) {
    const e57::Pose& p = *d.pose;
    t.linear() = Eigen::Quaterniond(p.rotation.w, p.rotation.x, p.rotation.y, p.rotation.z)
                     .normalized()
                     .toRotationMatrix();
    t.translation() = Eigen::Vector3d(p.translation.x, p.translation.y, p.translation.z);
  }
  return t;
}

// A full-sphere scan's angular step (radians) from its point count (scan_cloud.hpp).
double angular_step(const e57::Data3D& d) {
  return std::sqrt(4.0 * std::numbers::pi / std::max(static_cast<double>(d.point_count), 1.0));
}

using Progress = std::function<void(std::uint64_t, std::uint64_t)>;
using Sink = std::function<void(const ScanPiece&)>;

// Scan `si`'s valid points (file frame), colours and spacings (range * angular step), piece by
// piece.
void read_scan(const e57::Reader& reader, std::size_t si, const ScanCloudOptions& o,
               const Sink& sink, ScanCloudStats& s, std::uint64_t total, const Progress& progress) {
  const e57::Data3D& d = reader.scans()[si];
  const std::uint32_t intensity = e57::field_bit(e57::PointField::kIntensity);
  const std::uint32_t invalid = e57::field_bit(e57::PointField::kCartesianInvalidState);
  const bool has_rgb = (d.field_mask & kRgb) == kRgb;
  const bool has_i = !has_rgb && (d.field_mask & intensity) != 0;
  const std::uint32_t mask =
      kXyz | (has_rgb ? kRgb : 0u) | (has_i ? intensity : 0u) | (d.field_mask & invalid);
  s.colour = s.colour || has_rgb;
  const Eigen::Isometry3d world_from_scan = world_from_scan_of(d);
  const e57::ColorLimits cl = d.color_limits.value_or(e57::ColorLimits{0, 255, 0, 255, 0, 255});
  const e57::IntensityLimits il = d.intensity_limits.value_or(e57::IntensityLimits{0, 1});
  const double step = angular_step(d);
  e57::PointStream stream = reader.open_points(si, mask);
  e57::PointBuffer b;
  ScanPiece piece;
  while (stream.read(b, o.chunk_points) > 0) {
    piece.points.clear();
    piece.colours.clear();
    piece.spacings.clear();
    for (std::size_t i = 0; i < b.size; ++i) {
      if (!b.cartesian_invalid_state.empty() && b.cartesian_invalid_state[i] != 0) continue;
      const Eigen::Vector3d local(b.cartesian_x[i], b.cartesian_y[i], b.cartesian_z[i]);
      if (o.max_range > 0.0 && local.norm() > o.max_range) continue;
      piece.points.push_back((world_from_scan * local).cast<float>());
      piece.spacings.push_back(static_cast<float>(std::max(local.norm() * step, 1e-4)));
      if (has_rgb) {
        piece.colours.push_back({to_byte(b.color_red[i], cl.red_min, cl.red_max),
                                 to_byte(b.color_green[i], cl.green_min, cl.green_max),
                                 to_byte(b.color_blue[i], cl.blue_min, cl.blue_max)});
      } else if (has_i) {
        const std::uint8_t g = to_byte(b.intensity[i], il.minimum, il.maximum);
        piece.colours.push_back({g, g, g});
      } else {
        piece.colours.push_back({128, 128, 128});
      }
    }
    sink(piece);
    s.points_read += b.size;
    if (progress) progress(s.points_read, total);
  }
}

// Every scan of an E57 file with cartesian coordinates, in the file's frame; only those `want`
// accepts when it is given.
void read_e57(const std::filesystem::path& path, const ScanCloudOptions& o, const Sink& sink,
              ScanCloudStats& s, const Progress& progress,
              const std::function<bool(const e57::Data3D&)>& want = {}) {
  try {
    const e57::Reader reader(path);
    std::uint64_t total = 0;
    for (const e57::Data3D& d : reader.scans())
      total += d.point_count;
    for (std::size_t si = 0; si < reader.scans().size(); ++si) {
      if ((reader.scans()[si].field_mask & kXyz) != kXyz) continue;
      if (want && !want(reader.scans()[si])) continue;
      ++s.scans;
      read_scan(reader, si, o, sink, s, total, progress);
    }
  } catch (const e57::Error& e) {
    throw Error(std::string("cannot read the scan: ") + e.what(), {.file = path.string()});
  }
}

// A PLY or PCD cloud (point_file.hpp): no stations, so no spacing per point: the splats are
// the voxel's size. Grey where the file has no colour.
void read_point_file(const std::filesystem::path& path, const ScanCloudOptions& o, const Sink& sink,
                     ScanCloudStats& s, const Progress& progress) {
  PointFileReader reader(path);
  s.scans = 1;
  s.colour = reader.has_colour();
  PointBatch batch;
  ScanPiece piece;
  while (const std::size_t n = reader.read(batch, o.chunk_points)) {
    piece.points.clear();
    piece.colours.clear();
    for (std::size_t i = 0; i < batch.points.size(); ++i) {
      const Eigen::Vector3f& p = batch.points[i];
      if (o.max_range > 0.0 && p.norm() > o.max_range) continue;
      piece.points.push_back(p);
      piece.colours.push_back(s.colour ? batch.colours[i]
                                       : std::array<std::uint8_t, 3>{128, 128, 128});
    }
    sink(piece);
    s.points_read += n;
    if (progress) progress(s.points_read, reader.points_declared());
  }
}

// The stations' spacings give the finest-stations rule and the range splats (scan_cloud.hpp).
void add_piece(VoxelGrid& grid, const ScanPiece& piece) {
  for (std::size_t i = 0; i < piece.points.size(); ++i)
    grid.add(piece.points[i], piece.colours[i], piece.spacings.empty() ? 0.0f : piece.spacings[i]);
}

// The thinned cloud of a file, built while it is read (voxel_grid.hpp); a second reading when
// some voxels' sums need it.
render::PointCloud read_voxel_grid(const std::filesystem::path& path, const ScanCloudOptions& o,
                                   ScanCloudStats& s, std::uint64_t& valid,
                                   const Progress& progress) {
  const bool spaced =
      detect_point_file(path) == PointFileFormat::kE57 && o.range_splat_factor > 0.0;
  VoxelGrid grid(o.voxel_size, spaced);
  read_scan_pieces(
      path, o,
      [&](const ScanPiece& piece) {
        valid += piece.points.size();
        add_piece(grid, piece);
      },
      &s, progress);
  spdlog::debug("scan voxel grid: {} voxels, {:.0f} MB, {} to sum again", grid.voxels(),
                static_cast<double>(grid.bytes()) / 1e6, grid.ambiguous());
  if (grid.ambiguous() > 0) {
    spdlog::info("scan: reading again for {} of {} voxels (finest stations)", grid.ambiguous(),
                 grid.voxels());
    // A station whose nearest possible point in every such voxel is coarser than 1.5x the
    // voxel's finest spacing adds nothing there: it is not read again. The margin covers the
    // float rounding of the points' file-frame coordinates.
    const std::vector<VoxelGrid::Voxel> voxels = grid.ambiguous_voxels();
    const auto reaches = [&](const e57::Data3D& d) {
      const Eigen::Vector3d station = world_from_scan_of(d).translation();
      const double step = angular_step(d);
      return std::any_of(voxels.begin(), voxels.end(), [&](const VoxelGrid::Voxel& v) {
        const Eigen::Vector3d gap = (v.lo - station).cwiseMax(station - v.hi).cwiseMax(0.0);
        const double nearest = std::max((gap.norm() - 1e-3) * step, 1e-4);
        return nearest <= 1.5 * v.finest * (1.0 + 1e-5);
      });
    };
    grid.begin_second_pass();
    ScanCloudStats again;
    read_e57(
        path, o, [&](const ScanPiece& piece) { add_piece(grid, piece); }, again, {}, reaches);
    spdlog::debug("scan: {} of {} stations read again", again.scans, s.scans);
  }
  render::PointCloud out = grid.take_means();
  out.max_splat_pixels = o.max_splat_pixels;
  out.splat_size = base_splat(o);
  for (float& side : out.splat_sizes)
    side = splat_of(o, side);  // the mean spacing in, the splat out
  return out;
}

}  // namespace

void read_scan_pieces(const std::filesystem::path& path, const ScanCloudOptions& o,
                      const Sink& sink, ScanCloudStats* stats, const Progress& progress) {
  o.check();
  ScanCloudStats s;
  if (detect_point_file(path) != PointFileFormat::kE57) {
    read_point_file(path, o, sink, s, progress);
  } else {
    read_e57(path, o, sink, s, progress);
  }
  if (stats) {
    stats->scans = s.scans;
    stats->points_read = s.points_read;
    stats->colour = s.colour;
  }
}

render::PointCloud load_scan_cloud(const std::filesystem::path& path, const ScanCloudOptions& o,
                                   ScanCloudStats* stats, const Progress& progress) {
  o.check();
  Stopwatch watch;
  ScanCloudStats s;
  render::PointCloud out;
  std::uint64_t valid = 0;
  if (o.voxel_size > 0.0) {
    out = read_voxel_grid(path, o, s, valid, progress);
  } else {  // every point kept: the cloud is the file
    render::PointCloud all;
    read_scan_pieces(
        path, o,
        [&](const ScanPiece& piece) {
          valid += piece.points.size();
          all.points.insert(all.points.end(), piece.points.begin(), piece.points.end());
          all.colours.insert(all.colours.end(), piece.colours.begin(), piece.colours.end());
          all.splat_sizes.insert(all.splat_sizes.end(), piece.spacings.begin(),
                                 piece.spacings.end());
        },
        &s, progress);
    if (valid > 0) out = voxel_downsample(all, o);
  }
  if (s.scans == 0)
    throw Error("no scan with cartesian coordinates", {.file = path.string(), .field = "data3D"});
  if (valid == 0)
    throw Error("the scan holds no valid point", {.file = path.string(), .field = "data3D"});
  s.points_stray = remove_stray_points(out, o.stray);
  s.points_kept = out.points.size();
  s.ms = watch.elapsed_ms();
  if (stats) *stats = s;
  return out;
}

}  // namespace coloc::registration::align
