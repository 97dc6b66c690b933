#include "registration/twin/generator.hpp"

#include <spdlog/spdlog.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "registration/render/renderer.hpp"
#include "registration/twin/image_writer.hpp"
#include "registration/twin/scene.hpp"
#include "registration/twin/twin_io.hpp"
#include "slam/core/atomic_file.hpp"
#include "slam/core/error.hpp"
#include "slam/core/progress.hpp"
#include "slam/core/timing.hpp"
#include "slam/core/trajectory.hpp"

namespace coloc::registration::twin {
namespace {

namespace fs = std::filesystem;

std::string stamp(double t) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.6f", t);
  return buf;
}

void write_list_header(std::ostream& out, const std::string& title) {
  out << "# " << title << "\n# file: 'coloc digital twin'\n# timestamp filename\n";
}

// Colour (+ motion blur) and depth of one frame.
render::RenderResult render_frame(render::Renderer& renderer, const WalkTrajectory& walk,
                                  const GenerateOptions& o, double t) {
  render::RenderResult r =
      renderer.render(o.camera, walk.world_from_cam(t).inverse(), render::Layer::kMesh);
  if (o.motion_blur) {
    cv::Mat sum;
    r.colour.convertTo(sum, CV_32FC3);
    for (double dt : {-0.5 * o.exposure, 0.5 * o.exposure}) {
      const render::RenderResult s =
          renderer.render(o.camera, walk.world_from_cam(t + dt).inverse(), render::Layer::kMesh);
      cv::Mat f;
      s.colour.convertTo(f, CV_32FC3);
      sum += f;
    }
    sum.convertTo(r.colour, CV_8UC3, 1.0 / 3.0);
  }
  return r;
}

struct SequenceResult {
  Trajectory groundtruth;
  std::vector<double> render_ms;
};

SequenceResult write_sequence(render::Renderer& renderer, const WalkTrajectory& walk,
                              const GenerateOptions& o, const fs::path& dir) {
  fs::create_directories(dir / "rgb");
  fs::create_directories(dir / "depth");
  double end = walk.end_time();
  if (o.max_duration > 0.0) end = std::min(end, walk.start_time() + o.max_duration);
  const Trajectory frames = sample_trajectory(walk, o.fps, walk.start_time(), end);
  AtomicOutput rgb(dir / "rgb.txt");
  AtomicOutput depth(dir / "depth.txt");
  AtomicOutput assoc(dir / "associations.txt");
  write_list_header(rgb, "color images");
  write_list_header(depth, "depth maps");
  SequenceResult result;
  AsyncPngWriter png;  // encodes on a second thread while the next frame renders
  Progress progress("twin: RGB-D frames", frames.size(), o.quiet);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const double t = frames[i].timestamp;
    Stopwatch sw;
    render::RenderResult r = render_frame(renderer, walk, o, t);
    result.render_ms.push_back(sw.elapsed_ms());
    add_image_noise(r.colour, o.image_noise, o.seed * 1000003u + i);
    const cv::Mat mm = apply_depth_noise(r.depth, o.camera.fx, o.depth, o.seed * 7919u + i);
    cv::Mat bgr;
    cv::cvtColor(r.colour, bgr, cv::COLOR_RGB2BGR);
    const std::string name = stamp(t) + ".png";
    png.write(dir / "rgb" / name, bgr);
    png.write(dir / "depth" / name, mm);
    rgb << stamp(t) << " rgb/" << name << '\n';
    depth << stamp(t) << " depth/" << name << '\n';
    assoc << stamp(t) << " rgb/" << name << ' ' << stamp(t) << " depth/" << name << '\n';
    progress.advance();
  }
  png.close();
  progress.finish();
  result.groundtruth = frames;
  write_tum_trajectory(dir / "groundtruth.txt", frames);
  rgb.commit();
  depth.commit();
  assoc.commit();
  return result;
}

void write_headset(const WalkTrajectory& walk, const GenerateOptions& o, double end,
                   const fs::path& dir) {
  fs::create_directories(dir);
  HeadsetStreams h = simulate_headset(walk, o.headset, o.seed);
  const auto trim = [end](Trajectory& tr) {
    while (!tr.empty() && tr.back().timestamp > end + 1e-9)
      tr.pop_back();
  };
  trim(h.xr_from_headset);
  trim(h.world_from_headset);
  trim(h.world_from_xr);
  write_tum_trajectory(dir / "headset.txt", h.xr_from_headset);
  write_tum_trajectory(dir / "headset_groundtruth.txt", h.world_from_headset);
  write_tum_trajectory(dir / "xr_drift.txt", h.world_from_xr);
  io::write_headset_calibration(dir / "calibration.yaml", o.headset,
                                h.world_from_xr.front().world_from_cam);
}

// Stations are streamed face by face into the files (ScanSink): memory stays the same whatever
// the point count; only the stations' poses are kept.
std::vector<ScanStation> write_scan(render::Renderer& renderer, const TwinScene& scene,
                                    const GenerateOptions& o, const fs::path& dir,
                                    std::size_t& points) {
  fs::create_directories(dir);
  ScanFileWriter files(dir / "scan.e57", dir / "scan.ply", o.seed, o.scan.jpeg_quality);
  std::vector<ScanStation> stations;
  std::mt19937_64 rng(o.seed ^ 0x57a7105ull);
  std::uniform_real_distribution<double> yaw(-M_PI, M_PI);
  Progress progress("twin: scan stations", scene.plan.stations.size(), o.quiet);
  for (std::size_t k = 0; k < scene.plan.stations.size(); ++k) {
    const SE3 world_from_station(SO3::exp(Eigen::Vector3d(0, 0, yaw(rng))), scene.plan.stations[k]);
    stations.push_back(scan_station(renderer, static_cast<int>(k), world_from_station, o.scan,
                                    o.seed * 104729u + k, files));
    progress.advance();
  }
  progress.finish();
  points = files.close();
  return stations;
}

void write_summary(const fs::path& path, const GenerateOptions& o, const GenerateSummary& s) {
  AtomicOutput out(path);
  out << "%YAML:1.0\n# coloc digital twin (registration/twin/generator.hpp describes the files)\n"
      << "preset: " << preset_name(o.preset) << "\nseed: " << o.seed
      << "\nwalk_variant: " << o.walk_variant << "\nframes: " << s.frames << "\nfps: " << o.fps
      << "\nimu_samples: " << s.imu_samples << "\nheadset_poses: " << s.headset_poses
      << "\nstations: " << s.stations << "\nscan_points: " << s.scan_points
      << "\nmarkers: " << s.markers << "\nmarker_dictionary: " << o.dictionary
      << "\nmarker_size: " << o.marker_size << "\ntriangles: " << s.triangles
      << "\nmoved_furniture: " << s.moved_furniture << "\npath_length: " << s.path_length
      << "\nscan_face_size: " << o.scan.face_size << "\n";
  out.commit();
}

}  // namespace

PinholeCamera GenerateOptions::default_camera(int width, int height) {
  PinholeCamera c;
  c.width = width;
  c.height = height;
  const double s = width / 640.0;
  c.fx = 386.2 * s;
  c.fy = 385.7 * s;
  c.cx = 321.3 * s;
  c.cy = 238.6 * s;
  c.distortion = {-0.046, 0.034, 0.0004, -0.0003, 0.0};
  return c;
}

void GenerateOptions::check() const {
  if (camera.width < 16 || camera.height < 16 || !(camera.fx > 0) || !(camera.fy > 0)) {
    throw Error("camera needs width, height >= 16 and positive focal lengths", {.field = "camera"});
  }
  if (!(fps > 0.5 && fps <= 120.0)) throw Error("fps must be in (0.5, 120]", {.field = "fps"});
  if (max_duration < 0.0) throw Error("max_duration must be >= 0", {.field = "max_duration"});
  if (moved_furniture < 0 || moved_furniture > 100)
    throw Error("moved_furniture must be in 0..100", {.field = "moved_furniture"});
  if (image_noise < 0.0) throw Error("image_noise must be >= 0", {.field = "image_noise"});
  if (supersample < 1 || supersample % 2 == 0)
    throw Error("supersample must be odd", {.field = "supersample"});
  if (walk_variant < 0 || walk_variant > 2)
    throw Error("walk_variant must be 0, 1 or 2", {.field = "walk_variant"});
  walk.check();
  imu.check();
  headset.check();
  depth.check();
  scan.check();
}

GenerateOptions preset_options(Preset preset) {
  GenerateOptions o;
  o.preset = preset;
  switch (preset) {
    case Preset::kRoom:
      o.walk.speed = 0.45;
      o.walk.look_amplitude = 0.7;
      o.scan.point_step = 8;
      break;
    case Preset::kFloor:
      o.walk.speed = 0.8;
      break;
    case Preset::kBuilding:
      o.walk.speed = 1.0;
      o.walk.look_amplitude = 0.5;
      break;
    case Preset::kSite:
      // A surveyor's pace: the 406 m walk lasts 627 s (18,800 frames at 30 Hz), over the
      // 10 minutes asked for; the test walks as long.
      o.walk.speed = 0.65;
      o.walk.look_amplitude = 0.5;
      // 21 stations x 6 faces x (2560 / 2)^2 = 206 million points (every pixel hits a wall
      // indoors); --face-size 4096 --point-step 2 gives 528 million, --point-step 1 with
      // --face-size 2880 gives 1.05 billion.
      o.scan.face_size = 2560;
      o.scan.point_step = 2;
      // One marker per wall of each of the 15 rooms and corridors: 60 > DICT_4X4_50's ids.
      o.dictionary = 1;  // DICT_4X4_100
      break;
  }
  return o;
}

namespace {

// The path of walk `variant` (GenerateOptions::walk_variant): each waypoint moved sideways along
// the bisector of its two segments (furniture keeps 0.6 m from the path, walls more).
std::vector<Eigen::Vector2d> walk_path(const std::vector<Eigen::Vector2d>& path, int variant) {
  if (variant == 0 || path.size() < 2) return path;
  const double offset = variant == 1 ? 0.25 : -0.25;  // metres, + = left of the walking direction
  std::vector<Eigen::Vector2d> out(path.size());
  for (std::size_t i = 0; i < path.size(); ++i) {
    const Eigen::Vector2d in = (path[i] - path[i == 0 ? 0 : i - 1]).normalized();
    const Eigen::Vector2d on = (path[std::min(i + 1, path.size() - 1)] - path[i]).normalized();
    Eigen::Vector2d dir = i == 0 ? on : (i + 1 == path.size() ? in : (in + on).normalized());
    if (!dir.allFinite() || dir.norm() < 0.5) dir = on.allFinite() ? on : in;
    out[i] = path[i] + offset * Eigen::Vector2d(-dir.y(), dir.x());
  }
  return out;
}

}  // namespace

GenerateSummary generate_twin(const GenerateOptions& o, const fs::path& out) {
  o.check();
  Stopwatch total;
  GenerateSummary s;
  fs::create_directories(out);

  Stopwatch sw;
  SceneOptions so;
  so.preset = o.preset;
  so.dictionary = o.dictionary;
  so.marker_size = o.marker_size;
  so.texture_size = o.texture_size;
  const TwinScene scene = build_scene(so, o.seed);
  render::Renderer renderer(render::RenderOptions{.supersample = o.supersample});
  // Same seed, so the same plan, with some furniture moved: what the camera sees now.
  so.moved_furniture = o.moved_furniture;
  const TwinScene now = o.moved_furniture > 0 ? build_scene(so, o.seed) : TwinScene{};
  s.moved_furniture = static_cast<std::size_t>(now.moved_furniture);
  renderer.set_mesh(o.moved_furniture > 0 ? now.mesh : scene.mesh);
  s.markers = scene.markers.size();
  s.triangles = scene.mesh.triangle_count();
  s.seconds_scene = sw.elapsed_seconds();
  spdlog::info("twin: {} preset, seed {}: {} triangles, {} markers, {} stations ({:.2f} s)",
               preset_name(o.preset), o.seed, s.triangles, s.markers, scene.plan.stations.size(),
               s.seconds_scene);

  sw.restart();
  const WalkTrajectory walk(walk_path(scene.plan.path, o.walk_variant), o.walk,
                            o.seed + 1000003u * static_cast<std::uint64_t>(o.walk_variant));
  const fs::path seq = out / "sequence";
  const SequenceResult sr = write_sequence(renderer, walk, o, seq);
  s.frames = sr.groundtruth.size();
  s.render_ms_per_frame = summarize(sr.render_ms).median;
  for (std::size_t i = 1; i < sr.groundtruth.size(); ++i) {
    s.path_length += (sr.groundtruth[i].world_from_cam.translation() -
                      sr.groundtruth[i - 1].world_from_cam.translation())
                         .norm();
  }
  const double end = sr.groundtruth.back().timestamp;
  std::vector<ImuSample> imu;
  std::vector<ImuTruth> imu_truth;
  simulate_imu(walk, o.imu, o.seed, imu, imu_truth);
  while (!imu.empty() && imu.back().timestamp > end + 1e-9) {
    imu.pop_back();
    imu_truth.pop_back();
  }
  s.imu_samples = imu.size();
  io::write_imu(seq / "imu.txt", imu);
  io::write_imu_truth(seq / "imu_groundtruth.txt", imu_truth);
  io::write_camera_settings(seq / "camera.yaml", o.camera, o.fps, o.depth, o.imu, o.dictionary,
                            o.marker_size);
  write_headset(walk, o, end, out / "headset");
  s.headset_poses =
      static_cast<std::size_t>(std::floor((end - walk.start_time()) * o.headset.rate + 1e-9)) + 1;
  s.seconds_sequence = sw.elapsed_seconds();

  const fs::path gt = out / "groundtruth";
  fs::create_directories(gt);
  io::write_markers(gt / "markers.txt", gt / "marker_poses.txt", scene.markers, o.dictionary);
  {
    AtomicOutput offset(gt / "scan_from_sequence_start.txt");
    offset << "# world (scan) frame from the camera at the first frame: t tx ty tz qx qy qz qw\n"
           << io::tum_line(sr.groundtruth.front().timestamp, sr.groundtruth.front().world_from_cam)
           << '\n';
    offset.commit();
  }
  if (o.write_scan) {
    sw.restart();
    if (o.moved_furniture > 0) renderer.set_mesh(scene.mesh);
    std::vector<ScanStation> stations = write_scan(renderer, scene, o, out / "scan", s.scan_points);
    io::write_stations(out / "scan" / "stations.txt", out / "scan" / "faces.txt", stations);
    s.stations = stations.size();
    s.seconds_scan = sw.elapsed_seconds();
  }
  write_summary(out / "twin.yaml", o, s);
  s.seconds_total = total.elapsed_seconds();
  return s;
}

}  // namespace coloc::registration::twin
