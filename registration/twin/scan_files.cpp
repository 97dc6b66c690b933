#include <cstdio>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

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

}  // namespace

struct ScanFileWriter::Impl {
  std::unique_ptr<AtomicFile> e57_file;  // the E57 is written under its temporary name
  std::unique_ptr<e57::Writer> e57;
  std::unique_ptr<PlyWriter> ply;  // world-frame float xyz + RGB
  std::size_t points = 0;
  std::uint64_t seed = 0;
  int jpeg_quality = 92;
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
}

// Unclosed: the temporaries of both files are removed, their targets untouched.
ScanFileWriter::~ScanFileWriter() = default;

void ScanFileWriter::add(const ScanStation& st) {
  add_e57(st);
  for (std::size_t i = 0; i < st.points.size(); ++i) {
    const Eigen::Vector3f p = (st.world_from_station * st.points[i]).cast<float>();
    const auto& c = st.colours[i];
    impl_->ply->add(p.x(), p.y(), p.z(), c[0], c[1], c[2]);
  }
  impl_->points += st.points.size();
}

void ScanFileWriter::add_e57(const ScanStation& st) {
  using e57::FieldSpec;
  using e57::PointField;
  e57::Data3D header;
  header.guid = guid(impl_->seed, 0x5ca7, static_cast<std::uint64_t>(st.index));
  header.name = "station " + std::to_string(st.index);
  header.description = "coloc digital twin: synthetic terrestrial scan";
  header.sensor_vendor = "coloc";
  header.sensor_model = "twin virtual scanner";
  header.pose = to_e57(st.world_from_station);
  const std::vector<FieldSpec> fields{
      FieldSpec::scaled(PointField::kCartesianX, 1e-4, -200.0, 200.0),
      FieldSpec::scaled(PointField::kCartesianY, 1e-4, -200.0, 200.0),
      FieldSpec::scaled(PointField::kCartesianZ, 1e-4, -200.0, 200.0),
      FieldSpec::integer(PointField::kColorRed, 0, 255),
      FieldSpec::integer(PointField::kColorGreen, 0, 255),
      FieldSpec::integer(PointField::kColorBlue, 0, 255)};
  e57::PointBuffer buf;
  buf.reset(e57::field_bit(PointField::kCartesianX) | e57::field_bit(PointField::kCartesianY) |
                e57::field_bit(PointField::kCartesianZ) | e57::field_bit(PointField::kColorRed) |
                e57::field_bit(PointField::kColorGreen) | e57::field_bit(PointField::kColorBlue),
            st.points.size());
  for (std::size_t i = 0; i < st.points.size(); ++i) {
    buf.cartesian_x[i] = st.points[i].x();
    buf.cartesian_y[i] = st.points[i].y();
    buf.cartesian_z[i] = st.points[i].z();
    buf.color_red[i] = st.colours[i][0];
    buf.color_green[i] = st.colours[i][1];
    buf.color_blue[i] = st.colours[i][2];
  }
  impl_->e57->write_scan(header, fields, buf);

  const PinholeCamera& cam = st.face_camera;
  const double pixel = 1e-5;  // metres: a nominal 10 micron pixel; only focal/pixel matters
  for (std::size_t f = 0; f < 6; ++f) {
    e57::Image2D im;
    im.guid = guid(impl_->seed, 0x1a6e, static_cast<std::uint64_t>(st.index) * 6 + f);
    im.name = "station " + std::to_string(st.index) + " face " + std::to_string(f);
    im.description = "cube face; pose = world_from_camera, camera x right, y down, z forward";
    im.associated_data3d_guid = header.guid;
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
    cv::Mat bgr;
    cv::cvtColor(st.faces[f], bgr, cv::COLOR_RGB2BGR);
    std::vector<std::uint8_t> jpeg;
    cv::imencode(".jpg", bgr, jpeg, {cv::IMWRITE_JPEG_QUALITY, impl_->jpeg_quality});
    impl_->e57->add_image(im, jpeg);
  }
}

std::size_t ScanFileWriter::close() {
  impl_->e57->close();
  impl_->e57_file->commit();
  impl_->ply->commit();
  return impl_->points;
}

}  // namespace coloc::registration::twin
