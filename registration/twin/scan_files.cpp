#include <cstdio>
#include <cstring>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "e57io/writer.hpp"
#include "registration/twin/scan.hpp"
#include "slam/core/atomic_file.hpp"
#include "slam/core/error.hpp"
#include "slam/core/ply_writer.hpp"

namespace coloc::registration::twin {
namespace {

e57::Pose to_e57(const SE3& pose) {
  const Eigen::Quaterniond& q = pose.quaternion();
  return {{q.w(), q.x(), q.y(), q.z()},
          {pose.translation().x(), pose.translation().y(), pose.translation().z()}};
}

// Deterministic guid-shaped strings (E57 requires unique guids, not random ones).
std::string guid(std::uint64_t seed, std::uint64_t kind, std::uint64_t index) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "{%08llx-%04llx-4000-8000-%012llx}",
                static_cast<unsigned long long>(seed & 0xffffffffull),
                static_cast<unsigned long long>(kind & 0xffffull),
                static_cast<unsigned long long>(index & 0xffffffffffffull));
  return buf;
}

// Points go to the E57 writer in chunks of a multiple of its 4096-record encoding batch
// (e57io/compressed_vector_writer.cpp): its packets, and so the file's bytes, are then the same
// as for one write_scan of the whole station.
constexpr std::size_t kE57Chunk = 16 * 4096;

std::vector<e57::FieldSpec> point_fields() {
  using e57::FieldSpec;
  using e57::PointField;
  return {FieldSpec::scaled(PointField::kCartesianX, 1e-4, -200.0, 200.0),
          FieldSpec::scaled(PointField::kCartesianY, 1e-4, -200.0, 200.0),
          FieldSpec::scaled(PointField::kCartesianZ, 1e-4, -200.0, 200.0),
          FieldSpec::integer(PointField::kColorRed, 0, 255),
          FieldSpec::integer(PointField::kColorGreen, 0, 255),
          FieldSpec::integer(PointField::kColorBlue, 0, 255)};
}

}  // namespace

struct ScanFileWriter::Impl {
  std::unique_ptr<AtomicFile> e57_file;  // the E57 is written under its temporary name
  std::unique_ptr<e57::Writer> e57;
  std::unique_ptr<PlyWriter> ply;  // world-frame float xyz + RGB
  std::size_t points = 0;
  std::uint64_t seed = 0;
  int jpeg_quality = 92;
  // The open station: its geometry, points not yet given to the E57 writer, encoded faces.
  std::optional<ScanStation> station;
  std::string scan_guid;
  e57::PointBuffer pending;  // kE57Chunk long; the first `pending_count` are filled
  std::size_t pending_count = 0;
  std::array<std::vector<std::uint8_t>, 6> jpeg;
  std::vector<char> ply_bytes;
};

ScanFileWriter::ScanFileWriter(const std::filesystem::path& e57_path,
                               const std::filesystem::path& ply_path, std::uint64_t seed,
                               int jpeg_quality)
    : impl_(std::make_unique<Impl>()) {
  e57::WriterOptions wo;
  wo.guid = guid(seed, 0xf11e, 0);
  wo.creation_time = e57::DateTime{1.4e9, false};
  wo.library_version = "coloc twin generator";
  impl_->e57_file = std::make_unique<AtomicFile>(e57_path);
  impl_->e57 = std::make_unique<e57::Writer>(impl_->e57_file->temp_path(), wo);
  impl_->ply = std::make_unique<PlyWriter>(ply_path, ply_xyz_rgb(),
                                           "coloc digital twin scan, world frame, metres");
  impl_->seed = seed;
  impl_->jpeg_quality = jpeg_quality;
  using e57::PointField;
  impl_->pending.reset(
      e57::field_bit(PointField::kCartesianX) | e57::field_bit(PointField::kCartesianY) |
          e57::field_bit(PointField::kCartesianZ) | e57::field_bit(PointField::kColorRed) |
          e57::field_bit(PointField::kColorGreen) | e57::field_bit(PointField::kColorBlue),
      kE57Chunk);
}

// Unclosed: the temporaries of both files are removed, their targets untouched.
ScanFileWriter::~ScanFileWriter() = default;

void ScanFileWriter::begin_station(const ScanStation& st) {
  if (impl_->station) throw Error("begin_station while a station is open", {.field = "station"});
  impl_->station = st;
  e57::Data3D header;
  header.guid = guid(impl_->seed, 0x5ca7, static_cast<std::uint64_t>(st.index));
  header.name = "station " + std::to_string(st.index);
  header.description = "coloc digital twin: synthetic terrestrial scan";
  header.sensor_vendor = "coloc";
  header.sensor_model = "twin virtual scanner";
  header.pose = to_e57(st.world_from_station);
  impl_->scan_guid = header.guid;
  impl_->e57->begin_scan(header, point_fields());
  impl_->pending_count = 0;
  for (auto& j : impl_->jpeg)
    j.clear();
}

void ScanFileWriter::add_points(const ScanPoints& batch) {
  if (!impl_->station) throw Error("add_points without begin_station", {.field = "station"});
  Impl& m = *impl_;
  e57::PointBuffer& buf = m.pending;
  constexpr std::size_t kVertex = 3 * sizeof(float) + 3;
  m.ply_bytes.resize(batch.size() * kVertex);
  char* out = m.ply_bytes.data();
  for (std::size_t i = 0; i < batch.size(); ++i) {
    const Eigen::Vector3d& p = batch.xyz[i];
    const auto& c = batch.rgb[i];
    const std::size_t k = m.pending_count++;
    buf.cartesian_x[k] = p.x();
    buf.cartesian_y[k] = p.y();
    buf.cartesian_z[k] = p.z();
    buf.color_red[k] = c[0];
    buf.color_green[k] = c[1];
    buf.color_blue[k] = c[2];
    if (m.pending_count == kE57Chunk) flush_e57(kE57Chunk);
    const Eigen::Vector3f w = (m.station->world_from_station * p).cast<float>();
    std::memcpy(out, w.data(), 3 * sizeof(float));  // PLY: little-endian, as coloc's hosts
    std::memcpy(out + 3 * sizeof(float), c.data(), 3);
    out += kVertex;
  }
  m.ply->add_bytes(m.ply_bytes.data(), m.ply_bytes.size());
  m.points += batch.size();
}

void ScanFileWriter::flush_e57(std::size_t count) {
  impl_->pending.size = count;
  impl_->e57->add_points(impl_->pending);
  impl_->pending_count = 0;
}

void ScanFileWriter::add_face(std::size_t f, const cv::Mat& colour) {
  if (!impl_->station || f >= 6) throw Error("add_face outside a station", {.field = "face"});
  cv::Mat bgr;
  cv::cvtColor(colour, bgr, cv::COLOR_RGB2BGR);
  cv::imencode(".jpg", bgr, impl_->jpeg[f], {cv::IMWRITE_JPEG_QUALITY, impl_->jpeg_quality});
}

void ScanFileWriter::end_station() {
  if (!impl_->station) throw Error("end_station without begin_station", {.field = "station"});
  if (impl_->pending_count > 0) flush_e57(impl_->pending_count);
  impl_->e57->end_scan();
  const ScanStation& st = *impl_->station;
  const PinholeCamera& cam = st.face_camera;
  const double pixel = 1e-5;  // metres: a nominal 10 micron pixel; only focal/pixel matters
  for (std::size_t f = 0; f < 6; ++f) {
    if (impl_->jpeg[f].empty())
      throw Error("station ended without all six faces", {.field = "face"});
    e57::Image2D im;
    im.guid = guid(impl_->seed, 0x1a6e, static_cast<std::uint64_t>(st.index) * 6 + f);
    im.name = "station " + std::to_string(st.index) + " face " + std::to_string(f);
    im.description = "cube face; pose = world_from_camera, camera x right, y down, z forward";
    im.associated_data3d_guid = impl_->scan_guid;
    im.pose = to_e57(st.world_from_face[f]);
    im.representation = e57::ImageRepresentation::kPinhole;
    im.format = e57::ImageFormat::kJpeg;
    im.width = cam.width;
    im.height = cam.height;
    im.pixel_width = pixel;
    im.pixel_height = pixel;
    im.focal_length = cam.fx * pixel;
    im.principal_point_x = cam.cx;
    im.principal_point_y = cam.cy;
    impl_->e57->add_image(im, impl_->jpeg[f]);
  }
  for (auto& j : impl_->jpeg)
    j = {};
  impl_->station.reset();
}

std::size_t ScanFileWriter::close() {
  if (impl_->station) throw Error("close while a station is open", {.field = "station"});
  impl_->e57->close();
  impl_->e57_file->commit();
  impl_->ply->commit();
  return impl_->points;
}

}  // namespace coloc::registration::twin
