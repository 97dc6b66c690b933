#include "registration/align/sequence_cloud.hpp"

#include <spdlog/spdlog.h>

#include <array>
#include <cmath>
#include <limits>
#include <unordered_map>

#include "e57io/writer.hpp"
#include "slam/core/atomic_file.hpp"
#include "slam/core/error.hpp"
#include "slam/core/ply_writer.hpp"
#include "slam/core/trajectory.hpp"

namespace coloc::registration::align {
namespace {

// 21 bits per axis: +-10 km at 1 cm voxels.
std::uint64_t voxel_key(const Eigen::Vector3d& p, double size) {
  constexpr std::int64_t kHalf = std::int64_t{1} << 20;
  std::uint64_t key = 0;
  for (int a = 0; a < 3; ++a) {
    const auto cell = static_cast<std::int64_t>(std::floor(p[a] / size)) + kHalf;
    key =
        (key << 21) | static_cast<std::uint64_t>(std::clamp<std::int64_t>(cell, 0, 2 * kHalf - 1));
  }
  return key;
}

}  // namespace

VoxelFusion::VoxelFusion(double voxel_size) : voxel_size_(voxel_size) {
  if (!(voxel_size > 0.0 && std::isfinite(voxel_size)))
    throw Error("must be a positive number of metres", {.field = "voxel_size"});
}

void VoxelFusion::add(const Eigen::Vector3d& p, const std::array<std::uint8_t, 3>& rgb) {
  Voxel& voxel = grid_[voxel_key(p, voxel_size_)];
  voxel.position += p;
  for (std::size_t c = 0; c < 3; ++c)
    voxel.colour[c] += rgb[c];
  ++voxel.points;
  ++added_;
}

render::PointCloud VoxelFusion::cloud() const {
  render::PointCloud cloud;
  cloud.splat_size = static_cast<float>(voxel_size_);
  cloud.points.reserve(grid_.size());
  cloud.colours.reserve(grid_.size());
  for (const auto& [key, voxel] : grid_) {
    const double n = voxel.points;
    cloud.points.push_back((voxel.position / n).cast<float>());
    cloud.colours.push_back({static_cast<std::uint8_t>(std::lround(voxel.colour[0] / n)),
                             static_cast<std::uint8_t>(std::lround(voxel.colour[1] / n)),
                             static_cast<std::uint8_t>(std::lround(voxel.colour[2] / n))});
  }
  return cloud;
}

void SequenceCloudOptions::check() const {
  if (every < 1) throw Error("must be >= 1", {.field = "every"});
  if (!(voxel_size > 0.0 && std::isfinite(voxel_size)))
    throw Error("must be a positive number of metres", {.field = "voxel_size"});
  if (!(min_depth >= 0.0 && max_depth > min_depth && std::isfinite(max_depth)))
    throw Error("must satisfy 0 <= min_depth < max_depth", {.field = "max_depth"});
  if (!(max_pose_dt > 0.0)) throw Error("must be > 0 seconds", {.field = "max_pose_dt"});
}

render::PointCloud fuse_sequence(
    const dataset::Sequence& sequence, const Camera& camera, const SequenceCloudOptions& o,
    SequenceCloudStats* stats, const std::function<void(std::uint64_t, std::uint64_t)>& progress) {
  if (sequence.ground_truth().empty())
    throw Error("the sequence has no ground truth to place its frames with",
                {.file = sequence.folder().string()});
  return fuse_posed_frames(sequence, camera, sequence.ground_truth(), o, stats, progress);
}

render::PointCloud fuse_posed_frames(
    const dataset::Sequence& sequence, const Camera& camera, const Trajectory& truth,
    const SequenceCloudOptions& o, SequenceCloudStats* stats,
    const std::function<void(std::uint64_t, std::uint64_t)>& progress) {
  o.check();
  Trajectory frames;
  for (std::size_t i = 0; i < sequence.size(); i += o.every)
    frames.push_back({sequence.timestamp(i), SE3()});
  std::vector<std::optional<SE3>> pose_of(frames.size());
  for (const auto& [f, t] : associate_by_time(frames, truth, o.max_pose_dt))
    pose_of[f] = truth[t].world_from_cam;

  SequenceCloudStats s;
  VoxelFusion grid(o.voxel_size);
  for (std::size_t k = 0; k < frames.size(); ++k) {
    if (progress) progress(k + 1, frames.size());
    if (!pose_of[k]) {
      ++s.frames_without_pose;
      continue;
    }
    dataset::Frame frame;
    try {
      frame = sequence.frame(k * o.every);
    } catch (const Error& e) {
      spdlog::warn("frame {} skipped: {}", k * o.every, e.what());
      ++s.frames_unreadable;
      continue;
    }
    if (frame.depth.empty()) continue;
    const SE3& world_from_cam = *pose_of[k];
    const bool colour = frame.color.type() == CV_8UC3 && frame.color.size() == frame.depth.size();
    for (int v = 0; v < frame.depth.rows; ++v) {
      const float* depth = frame.depth.ptr<float>(v);
      for (int u = 0; u < frame.depth.cols; ++u) {
        const double d = depth[u];
        if (!(d >= o.min_depth && d <= o.max_depth)) continue;
        const Eigen::Vector3d p = world_from_cam * backproject(camera, {u, v}, d);
        if (colour) {
          const cv::Vec3b bgr = frame.color.at<cv::Vec3b>(v, u);
          grid.add(p, {bgr[2], bgr[1], bgr[0]});
        } else {
          grid.add(p, {128, 128, 128});
        }
        ++s.depth_points;
      }
    }
    ++s.frames_used;
  }
  if (s.frames_used == 0)
    throw Error(
        "no frame had a pose within " + std::to_string(o.max_pose_dt) + " s and readable depth",
        {.file = sequence.folder().string()});
  if (stats) *stats = s;
  return grid.cloud();
}

void write_point_cloud(const std::filesystem::path& path, const render::PointCloud& cloud,
                       const std::string& description) {
  const std::string extension = path.extension().string();
  if (extension == ".ply") {
    PlyWriter ply(path, ply_xyz_rgb(), description);
    for (std::size_t i = 0; i < cloud.points.size(); ++i) {
      const Eigen::Vector3f& p = cloud.points[i];
      const auto& c = cloud.colours[i];
      ply.add(p.x(), p.y(), p.z(), c[0], c[1], c[2]);
    }
    ply.commit();
    return;
  }
  if (extension != ".e57")
    throw Error("the output must end in .ply or .e57", {.file = path.string()});
  using e57::FieldSpec;
  using e57::PointField;
  AtomicFile file(path);
  e57::WriterOptions wo;
  wo.guid = e57::make_guid();
  wo.library_version = "coloc scan from-sequence";
  e57::Writer writer(file.temp_path(), wo);
  e57::Data3D header;
  header.guid = e57::make_guid();
  header.name = path.stem().string();
  header.description = description;
  // Coordinates to 0.1 mm within the cloud's bounds (E57's scaled integers).
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
  Eigen::Vector3f hi = -lo;
  for (const auto& p : cloud.points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const std::vector<FieldSpec> fields{
      FieldSpec::scaled(PointField::kCartesianX, 1e-4, lo.x() - 1.0, hi.x() + 1.0),
      FieldSpec::scaled(PointField::kCartesianY, 1e-4, lo.y() - 1.0, hi.y() + 1.0),
      FieldSpec::scaled(PointField::kCartesianZ, 1e-4, lo.z() - 1.0, hi.z() + 1.0),
      FieldSpec::integer(PointField::kColorRed, 0, 255),
      FieldSpec::integer(PointField::kColorGreen, 0, 255),
      FieldSpec::integer(PointField::kColorBlue, 0, 255)};
  writer.begin_scan(header, fields);
  constexpr std::size_t kChunk = 1 << 16;
  e57::PointBuffer buffer;
  for (std::size_t start = 0; start < cloud.points.size(); start += kChunk) {
    const std::size_t n = std::min(kChunk, cloud.points.size() - start);
    buffer.reset(
        e57::field_bit(PointField::kCartesianX) | e57::field_bit(PointField::kCartesianY) |
            e57::field_bit(PointField::kCartesianZ) | e57::field_bit(PointField::kColorRed) |
            e57::field_bit(PointField::kColorGreen) | e57::field_bit(PointField::kColorBlue),
        n);
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector3f& p = cloud.points[start + i];
      const auto& c = cloud.colours[start + i];
      buffer.cartesian_x[i] = p.x();
      buffer.cartesian_y[i] = p.y();
      buffer.cartesian_z[i] = p.z();
      buffer.color_red[i] = c[0];
      buffer.color_green[i] = c[1];
      buffer.color_blue[i] = c[2];
    }
    writer.add_points(buffer);
  }
  writer.end_scan();
  writer.close();
  file.commit();
}

}  // namespace coloc::registration::align
