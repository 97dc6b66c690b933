// coloc twin generate: the seeded digital twin (registration/twin); coloc bench render: speed of
// the OSMesa renderer (registration/render).

#include <cstdio>

#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/verbs.hpp"
#include "registration/render/renderer.hpp"
#include "registration/twin/generator.hpp"
#include "registration/twin/scene.hpp"
#include "slam/core/cube_map.hpp"
#include "slam/core/timing.hpp"

namespace coloc::cli {
namespace {

namespace twin = registration::twin;
namespace render = registration::render;

struct TwinArgs {
  std::string preset = "room";
  std::uint64_t seed = 1;
  int walk = 0;  // GenerateOptions::walk_variant
  int moved_furniture = 0;
  std::string out;
  double seconds = 0.0;
  int face_size = 0;
  int point_step = 0;
  int supersample = 1;
  bool no_scan = false;
  bool motion_blur = false;
  double depth_noise = 1.0;  // scales the D455 disparity noise (0: exact depth)
  bool json = false;
  int dictionary = -1;  // -1: the preset's (site: DICT_4X4_100, else DICT_4X4_50)
  double marker_size = 0.1675;
};

void run_generate(const TwinArgs& a) {
  twin::GenerateOptions o = twin::preset_options(twin::parse_preset(a.preset));
  o.seed = a.seed;
  o.walk_variant = a.walk;
  o.moved_furniture = a.moved_furniture;
  o.max_duration = a.seconds;
  o.supersample = a.supersample;
  o.motion_blur = a.motion_blur;
  o.depth.disparity_sigma *= a.depth_noise;
  o.write_scan = !a.no_scan;
  o.quiet = a.json;
  if (a.dictionary >= 0) o.dictionary = a.dictionary;
  o.marker_size = a.marker_size;
  if (a.face_size > 0) o.scan.face_size = a.face_size;
  if (a.point_step > 0) o.scan.point_step = a.point_step;
  const twin::GenerateSummary s = twin::generate_twin(o, a.out);
  if (a.json) {
    print_json({{"preset", a.preset},
                {"seed", a.seed},
                {"out", a.out},
                {"frames", s.frames},
                {"imu_samples", s.imu_samples},
                {"headset_poses", s.headset_poses},
                {"stations", s.stations},
                {"scan_points", s.scan_points},
                {"markers", s.markers},
                {"triangles", s.triangles},
                {"moved_furniture", s.moved_furniture},
                {"path_length_m", s.path_length},
                {"seconds_scene", s.seconds_scene},
                {"seconds_sequence", s.seconds_sequence},
                {"seconds_scan", s.seconds_scan},
                {"seconds_total", s.seconds_total},
                {"render_ms_per_frame", s.render_ms_per_frame}});
    return;
  }
  std::printf("twin '%s' seed %llu -> %s\n", a.preset.c_str(),
              static_cast<unsigned long long>(a.seed), a.out.c_str());
  std::printf("  scene     %zu triangles, %zu markers (%.2f s)\n", s.triangles, s.markers,
              s.seconds_scene);
  std::printf(
      "  sequence  %zu frames, %.1f m walked, %zu IMU samples, %zu headset poses (%.1f s,"
      " render %.1f ms/frame median)\n",
      s.frames, s.path_length, s.imu_samples, s.headset_poses, s.seconds_sequence,
      s.render_ms_per_frame);
  std::printf("  scan      %zu stations, %zu points (%.1f s)\n", s.stations, s.scan_points,
              s.seconds_scan);
  std::printf("  total     %.1f s\n", s.seconds_total);
}

struct TwinBenchArgs {
  int width = 640;
  int height = 480;
  int frames = 60;
  int face_size = 2048;
  int faces = 6;
  std::string preset = "room";
};

void print_stats(const char* what, const std::vector<double>& ms) {
  const SampleStats s = summarize(ms);
  std::printf("  %-34s median %8.2f ms   p99 %8.2f ms   (%zu runs)\n", what, s.median, s.p99,
              s.count);
}

void run_bench(const TwinBenchArgs& a) {
  const twin::GenerateOptions o = twin::preset_options(twin::parse_preset(a.preset));
  twin::SceneOptions so;
  so.preset = o.preset;
  so.dictionary = o.dictionary;
  const twin::TwinScene scene = twin::build_scene(so, 1);
  render::Renderer renderer;
  renderer.set_mesh(scene.mesh);
  const twin::WalkTrajectory walk(scene.plan.path, o.walk, 1);
  PinholeCamera cam = twin::GenerateOptions::default_camera(a.width, a.height);
  PinholeCamera ideal = cam;
  ideal.distortion = {};
  std::printf("coloc bench render: OSMesa (llvmpipe), '%s' scene, %zu triangles\n",
              a.preset.c_str(), scene.mesh.triangle_count());
  std::vector<double> with, without, faces, cloud;
  renderer.render(cam, walk.world_from_cam(walk.start_time()).inverse());  // warm-up (JIT)
  for (int i = 0; i < a.frames; ++i) {
    const double t = walk.start_time() + (walk.end_time() - walk.start_time()) * i / a.frames;
    const SE3 pose = walk.world_from_cam(t).inverse();
    Stopwatch sw;
    renderer.render(ideal, pose, render::Layer::kMesh);
    without.push_back(sw.elapsed_ms());
    sw.restart();
    renderer.render(cam, pose, render::Layer::kMesh);
    with.push_back(sw.elapsed_ms());
  }
  char label[96];
  std::snprintf(label, sizeof(label), "mesh %dx%d colour+depth+points", a.width, a.height);
  print_stats(label, without);
  std::snprintf(label, sizeof(label), "  same with distortion post-warp");
  print_stats(label, with);

  // Cube faces at a station, and the resulting scan point cloud rendered as splats.
  twin::ScanOptions scan;
  scan.face_size = a.face_size;
  scan.point_step = std::max(1, a.face_size / 512);
  const auto rotations = cube_face_rotations();
  const PinholeCamera face = cube_face_camera(a.face_size);
  const SE3 world_from_station(SO3(), scene.plan.stations.front());
  for (int f = 0; f < a.faces; ++f) {
    Stopwatch sw;
    renderer.render(face,
                    (world_from_station *
                     SE3(rotations[static_cast<std::size_t>(f % 6)], Eigen::Vector3d::Zero()))
                        .inverse(),
                    render::Layer::kMesh);
    faces.push_back(sw.elapsed_ms());
  }
  std::snprintf(label, sizeof(label), "cube face %dx%d", a.face_size, a.face_size);
  print_stats(label, faces);

  twin::ScanCollector station;
  twin::scan_station(renderer, 0, world_from_station, scan, 1, station);
  render::PointCloud pc;
  pc.splat_size = 0.02f;
  for (std::size_t i = 0; i < station.points.size(); ++i) {
    pc.points.push_back((world_from_station * station.points.xyz[i]).cast<float>());
    pc.colours.push_back(station.points.rgb[i]);
  }
  renderer.set_point_cloud(pc);
  for (int i = 0; i < a.frames; ++i) {
    const double t = walk.start_time() + (walk.end_time() - walk.start_time()) * i / a.frames;
    Stopwatch sw;
    renderer.render(ideal, walk.world_from_cam(t).inverse(), render::Layer::kPoints);
    cloud.push_back(sw.elapsed_ms());
  }
  std::snprintf(label, sizeof(label), "point cloud %zu pts %dx%d", pc.points.size(), a.width,
                a.height);
  print_stats(label, cloud);
}

}  // namespace

void add_twin_verb(CLI::App& app, CLI::App& bench) {
  CLI::App* twin_cmd = app.add_subcommand("twin", "Synthetic building with exact ground truth");
  twin_cmd->require_subcommand(1);
  auto args = std::make_shared<TwinArgs>();
  CLI::App* gen = twin_cmd->add_subcommand(
      "generate", "Write scene, RGB-D sequence (TUM), IMU, headset poses and laser scan (E57)");
  gen->add_option("--preset", args->preset,
                  "Scene size: room, floor, building, or site (the paper's scale: 11 rooms, "
                  "551 m2, a 10-minute walk, 21 stations, 206 M scan points; the test walks "
                  "--walk 1|2 --no-scan --seconds 180 keep them to 5,400 frames)")
      ->check(CLI::IsMember({"room", "floor", "building", "site"}))
      ->capture_default_str();
  gen->add_option("--seed", args->seed, "Random seed (same seed, same files)")
      ->capture_default_str();
  gen->add_option("--out", args->out, "Output directory")->required();
  gen->add_option("--walk", args->walk,
                  "Another walk through the same building: 1 / 2 = 0.25 m left / right of the "
                  "preset's path, other head motion (scene and scan unchanged)")
      ->check(CLI::Range(0, 2));
  gen->add_option("--seconds", args->seconds, "Limit the sequence to this many seconds (0 = all)");
  gen->add_option("--face-size", args->face_size,
                  "Scan cube-face size in pixels (default 2048; site 2560)");
  gen->add_option("--point-step", args->point_step,
                  "One scan point every N face pixels (default 8; site 2). Points = stations x 6 "
                  "x (face-size / point-step)^2: the site with --face-size 2880 --point-step 1 "
                  "is 1.05 billion (files stream, memory stays the same)");
  gen->add_option("--supersample", args->supersample, "Odd colour supersampling factor")
      ->capture_default_str();
  gen->add_option("--dictionary", args->dictionary,
                  "ArUco dictionary: OpenCV predefined id (0 = DICT_4X4_50, 1 = DICT_4X4_100, "
                  "10 = DICT_6X6_250; default: the preset's, site 1, others 0)");
  gen->add_option("--marker-size", args->marker_size, "Marker black-square edge (m)")
      ->capture_default_str();
  gen->add_option("--moved-furniture", args->moved_furniture,
                  "Pieces of furniture moved 0.8 m between the scan and the sequence")
      ->check(CLI::Range(0, 100));
  gen->add_flag("--no-scan", args->no_scan, "Skip the laser scan");
  gen->add_flag("--motion-blur", args->motion_blur, "Average 3 renders over the exposure");
  gen->add_option("--depth-noise", args->depth_noise,
                  "Scale of the depth camera's disparity noise (1: D455-like, 0: exact depth; "
                  "dropouts and quantization stay)")
      ->check(CLI::Range(0.0, 10.0));
  gen->add_flag("--json", args->json, "Machine-readable summary on stdout");
  gen->callback([args] { run_generate(*args); });

  auto b = std::make_shared<TwinBenchArgs>();
  CLI::App* cmd = bench.add_subcommand("render", "OSMesa renderer: ms per frame and cube face");
  cmd->add_option("--width", b->width, "Frame width")->capture_default_str();
  cmd->add_option("--height", b->height, "Frame height")->capture_default_str();
  cmd->add_option("--frames", b->frames, "Frames to render")->capture_default_str();
  cmd->add_option("--face-size", b->face_size, "Cube-face size")->capture_default_str();
  cmd->add_option("--faces", b->faces, "Cube faces to render")->capture_default_str();
  cmd->add_option("--preset", b->preset, "Scene")
      ->check(CLI::IsMember({"room", "floor", "building", "site"}))
      ->capture_default_str();
  cmd->callback([b] { run_bench(*b); });
}

}  // namespace coloc::cli
