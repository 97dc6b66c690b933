#include "registration/twin/scan.hpp"

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>

#include "slam/core/cube_map.hpp"
#include "slam/core/error.hpp"

namespace coloc::registration::twin {

void ScanOptions::check() const {
  if (face_size < 16 || face_size > 8192)
    throw Error("face_size must be in 16..8192", {.field = "face_size"});
  if (point_step < 1 || point_step > face_size)
    throw Error("point_step must be in 1..face_size", {.field = "point_step"});
  if (range_noise < 0.0) throw Error("range_noise must be >= 0", {.field = "range_noise"});
  if (!(max_range > 0.0)) throw Error("max_range must be > 0", {.field = "max_range"});
  if (jpeg_quality < 1 || jpeg_quality > 100)
    throw Error("jpeg_quality must be in 1..100", {.field = "jpeg_quality"});
}

ScanStation scan_station(render::Renderer& renderer, int index, const SE3& world_from_station,
                         const ScanOptions& options, std::uint64_t seed, ScanSink& sink) {
  options.check();
  ScanStation st;
  st.index = index;
  st.world_from_station = world_from_station;
  st.face_camera = cube_face_camera(options.face_size);
  const auto rotations = cube_face_rotations();
  for (std::size_t f = 0; f < 6; ++f)
    st.world_from_face[f] = world_from_station * SE3(rotations[f], Eigen::Vector3d::Zero());
  sink.begin_station(st);
  // One generator over the whole station in a fixed order: the points do not depend on how
  // they are batched.
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, options.range_noise);
  const SE3 station_from_world = world_from_station.inverse();
  const int step = options.point_step;
  ScanPoints batch;
  batch.xyz.reserve(kScanBatch);
  batch.rgb.reserve(kScanBatch);
  for (std::size_t f = 0; f < 6; ++f) {
    const render::RenderResult r =
        renderer.render(st.face_camera, st.world_from_face[f].inverse(), render::Layer::kMesh);
    for (int v = step / 2; v < options.face_size; v += step) {
      for (int u = step / 2; u < options.face_size; u += step) {
        const cv::Vec3f p = r.points.at<cv::Vec3f>(v, u);
        if (std::isnan(p[0])) continue;
        Eigen::Vector3d ps = station_from_world * Eigen::Vector3d(p[0], p[1], p[2]);
        const double range = ps.norm();
        if (range > options.max_range || range < 1e-3) continue;
        ps *= (range + noise(rng)) / range;
        const cv::Vec3b c = r.colour.at<cv::Vec3b>(v, u);
        batch.xyz.push_back(ps);
        batch.rgb.push_back({c[0], c[1], c[2]});
        if (batch.size() == kScanBatch) {
          sink.add_points(batch);
          batch.clear();
        }
      }
    }
    if (batch.size() > 0) sink.add_points(batch);
    batch.clear();
    sink.add_face(f, r.colour);
  }
  sink.end_station();
  return st;
}

}  // namespace coloc::registration::twin
