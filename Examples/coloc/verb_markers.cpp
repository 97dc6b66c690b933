// coloc markers detect IMAGE..., coloc scan-markers SCAN.e57, coloc bench markers: ArUco /
// AprilTag detection in single images, marker positions from a laser scan's images, and the
// detection cost per frame that SLAM keyframes pay.

#include <spdlog/spdlog.h>

#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <random>
#include <sstream>

#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/verbs.hpp"
#include "markers/detector.hpp"
#include "markers/dictionary.hpp"
#include "markers/marker_map.hpp"
#include "markers/marker_pose.hpp"
#include "markers/scan_markers.hpp"
#include "markers/synthetic.hpp"
#include "slam/core/error.hpp"
#include "slam/core/input_file.hpp"
#include "slam/core/timing.hpp"
#include "slam/settings/settings.hpp"

namespace coloc::cli {
namespace {

namespace fs = std::filesystem;
using markers::CornerRefinement;

const std::map<std::string, CornerRefinement> kRefinements{
    {"none", CornerRefinement::kNone},
    {"subpixel", CornerRefinement::kSubpixel},
    {"contour", CornerRefinement::kContour},
    {"apriltag", CornerRefinement::kAprilTag},
    {"edges", CornerRefinement::kEdgeLines}};

struct DetectArgs {
  std::vector<std::string> images;
  std::string dictionary;
  std::string refine = "subpixel";
  std::string params;
  double size = 0.0;
  std::string camera;
  bool json = false;
};

// One detection's pose (with --camera): JSON fields added to `j`, text lines appended to `text`.
void describe_pose(const std::optional<markers::MarkerPose>& pose, Json& j,
                   std::ostringstream& text) {
  if (!pose) {
    j["camera_from_marker"] = nullptr;
    text << "\n    no pose (degenerate corners)";
    return;
  }
  const double angle_deg = pose->candidate_angle() * 180.0 / M_PI;
  j["camera_from_marker"] = json_row_major(pose->camera_from_marker().matrix());
  j["reprojection_error_px"] = pose->reprojection_error_px();
  j["distance_m"] = pose->distance();
  j["ambiguous"] = pose->ambiguous;
  j["alternative"] = {
      {"camera_from_marker", json_row_major(pose->alternative.camera_from_marker.matrix())},
      {"reprojection_error_px", pose->alternative.reprojection_error_px},
      {"angle_deg", angle_deg}};
  char buf[200];
  std::snprintf(buf, sizeof buf, "\n    reprojection %.3f px, distance %.3f m",
                pose->reprojection_error_px(), pose->distance());
  text << buf;
  if (pose->ambiguous) {
    std::snprintf(buf, sizeof buf,
                  "; AMBIGUOUS: the mirrored pose (%.1f deg away) reprojects with %.3f px",
                  angle_deg, pose->alternative.reprojection_error_px);
    text << buf;
  }
  const Eigen::Matrix4d m = pose->camera_from_marker().matrix();
  text << "\n    camera_from_marker:";
  for (int r = 0; r < 3; ++r) {
    std::snprintf(buf, sizeof buf, "\n      [% .6f % .6f % .6f % .6f]", m(r, 0), m(r, 1), m(r, 2),
                  m(r, 3));
    text << buf;
  }
}

void detect(const DetectArgs& a) {
  markers::DetectorOptions options;
  options.dictionary = a.dictionary;
  options.corner_refinement = kRefinements.at(a.refine);
  options.parameters_file = a.params;
  const markers::MarkerDetector detector(options);
  std::optional<Camera> camera;
  if (!a.camera.empty()) camera = settings::load_settings(a.camera).camera;
  const markers::PoseOptions pose_options{.marker_size = a.size};

  Json images = Json::array();
  int total = 0;
  for (const std::string& file : a.images) {
    check_input_file(file, "image");
    const cv::Mat image = cv::imread(file, cv::IMREAD_GRAYSCALE);
    if (image.empty()) throw Error("cannot read image", {.file = file});
    const auto observations = detector.detect(image);
    total += static_cast<int>(observations.size());
    if (!a.json) std::cout << file << ": " << observations.size() << " markers\n";
    Json found = Json::array();
    for (const auto& o : observations) {
      Json corners = Json::array();
      std::ostringstream text;
      text << "  id " << o.id << ": corners";
      for (int c = 0; c < 4; ++c) {
        corners.push_back({o.corners[c].x(), o.corners[c].y()});
        char buf[64];
        std::snprintf(buf, sizeof buf, " (%.2f, %.2f)", o.corners[c].x(), o.corners[c].y());
        text << buf;
      }
      Json j = {{"id", o.id}, {"corners", corners}};
      if (camera) describe_pose(markers::estimate_marker_pose(*camera, o, pose_options), j, text);
      found.push_back(std::move(j));
      if (!a.json) std::cout << text.str() << "\n";
    }
    images.push_back(
        {{"file", file}, {"width", image.cols}, {"height", image.rows}, {"markers", found}});
  }
  if (a.json) print_json({{"dictionary", a.dictionary}, {"images", images}});
  if (total == 0) spdlog::warn("no markers of {} found", a.dictionary);
}

// Ground truth corners as the digital twin writes them (groundtruth/markers.txt):
// "id size x0 y0 z0 ... x3 y3 z3" per line, '#' comments.
std::map<int, std::array<Eigen::Vector3d, 4>> read_truth(const std::string& path) {
  check_input_file(path, "ground truth");
  std::ifstream in(path);
  if (!in) throw Error("cannot open ground truth", {.file = path});
  std::map<int, std::array<Eigen::Vector3d, 4>> truth;
  std::string line;
  std::int64_t n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream s(line);
    int id = 0;
    double size = 0.0;
    std::array<Eigen::Vector3d, 4> c;
    s >> id >> size;
    for (auto& p : c)
      s >> p.x() >> p.y() >> p.z();
    if (!s) throw Error("want: id size and 12 corner coordinates", {.file = path, .line = n});
    truth[id] = c;
  }
  return truth;
}

struct ScanArgs {
  std::string scan, dictionary, out, debug, truth, refine = "edges";
  double size = 0.0, max_reprojection = 1.0, max_distance = 3.0;
  int face_size = 2048;
  bool json = false;
};

void report_scan(const ScanArgs& a, const markers::ScanMarkersResult& r);

void scan_markers_verb(const ScanArgs& a) {
  markers::ScanMarkerOptions o;
  o.detector.dictionary = a.dictionary;
  o.detector.corner_refinement = kRefinements.at(a.refine);
  o.pose.marker_size = a.size;
  o.max_reprojection_error_px = a.max_reprojection;
  o.max_distance = a.max_distance;
  o.cube_face_size = a.face_size;
  o.debug_dir = a.debug;
  o.quiet = a.json;
  const markers::ScanMarkersResult r = markers::scan_markers(a.scan, o);

  std::map<std::string, int> rejected;
  for (const auto& x : r.rejected)
    ++rejected[markers::to_string(x.reason)];
  std::cerr << "searched " << r.images_searched << " images (" << r.faces_searched
            << " pinhole images / cube faces), " << r.skipped.size() << " skipped; "
            << r.sightings.size() << " sightings kept, " << r.rejected.size() << " rejected";
  for (const auto& [why, count] : rejected)
    std::cerr << " [" << why << ": " << count << "]";
  std::cerr << "\n";
  if (r.map.markers.empty()) {
    throw CliFailure("no markers found in " + std::to_string(r.faces_searched) + " images of " +
                     a.scan + " (" + std::to_string(r.rejected.size()) +
                     " detections rejected by the filters; check --dictionary, --size, "
                     "--max-distance, or look at --debug)");
  }
  markers::write_marker_map(a.out, r.map);
  report_scan(a, r);
}

// Prints the fused markers (and, with --truth, their corner errors) as text or JSON.
void report_scan(const ScanArgs& a, const markers::ScanMarkersResult& r) {
  std::map<int, std::array<Eigen::Vector3d, 4>> truth;
  if (!a.truth.empty()) truth = read_truth(a.truth);
  Json found = Json::array();
  double sum = 0.0, worst = 0.0;
  int corners = 0, missing = 0;
  for (const auto& [id, m] : r.map.markers) {
    Json j = {{"id", id},
              {"sightings", m.sightings},
              {"rejected_sightings", m.rejected_sightings},
              {"residual_m", m.residual}};
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "marker %3d: %d sightings (%d dropped, %d ambiguous), residual %.2f mm", id,
                  m.sightings, m.rejected_sightings, m.ambiguous_sightings, 1e3 * m.residual);
    std::string line = buf;
    if (truth.count(id)) {
      double marker_max = 0.0;
      for (int c = 0; c < 4; ++c) {
        const double e = (m.corners[c] - truth.at(id)[c]).norm();
        sum += e;
        worst = std::max(worst, e);
        marker_max = std::max(marker_max, e);
        ++corners;
      }
      std::snprintf(buf, sizeof buf, ", corner error max %.2f mm", 1e3 * marker_max);
      line += buf;
      j["corner_error_max_m"] = marker_max;
    }
    found.push_back(std::move(j));
    if (!a.json) std::cout << line << "\n";
  }
  for (const auto& [id, c] : truth)
    missing += r.map.markers.count(id) == 0 ? 1 : 0;
  Json summary = {{"out", a.out},
                  {"images_searched", r.images_searched},
                  {"faces_searched", r.faces_searched},
                  {"sightings", r.sightings.size()},
                  {"rejected", r.rejected.size()},
                  {"markers", found}};
  if (!truth.empty()) {
    summary["truth"] = {{"corners", corners},
                        {"mean_m", corners ? sum / corners : 0.0},
                        {"max_m", worst},
                        {"markers_missing", missing}};
    if (!a.json) {
      std::printf(
          "ground truth: %d corners of %zu markers, error mean %.2f mm, max %.2f mm; %d of %zu "
          "true markers not found\n",
          corners, r.map.markers.size(), corners ? 1e3 * sum / corners : 0.0, 1e3 * worst, missing,
          truth.size());
    }
  }
  if (a.json) {
    print_json(summary);
  } else {
    std::cout << "wrote " << r.map.markers.size() << " markers to " << a.out << "\n";
  }
}

struct MarkerBenchArgs {
  int frames = 200;
  std::string dictionary = "DICT_4X4_50";
};

// A 640x480 (or larger) frame like a keyframe: textured background, a few markers at random
// poses and distances, blur and noise.
cv::Mat bench_frame(const PinholeCamera& camera, const cv::aruco::Dictionary& dictionary,
                    std::mt19937& rng) {
  cv::Mat image(camera.height, camera.width, CV_8UC1);
  cv::randu(image, 40, 200);
  cv::GaussianBlur(image, image, cv::Size(0, 0), 3.0);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int k = 0; k < 3; ++k) {
    const double z = 0.8 + 1.2 * (u(rng) + 1.0);
    const SE3 pose(SO3::from_axis_angle(Eigen::Vector3d::UnitX(), M_PI) *
                       SO3::exp(Eigen::Vector3d(0.5 * u(rng), 0.5 * u(rng), 0.3 * u(rng))),
                   Eigen::Vector3d(0.3 * z * u(rng), 0.2 * z * u(rng), z));
    markers::render_marker(image, camera, pose, dictionary, k, 0.1675, {.supersample = 2});
  }
  cv::GaussianBlur(image, image, cv::Size(0, 0), 0.7);
  return image;
}

void bench_markers(const MarkerBenchArgs& a) {
  const auto dictionary = markers::make_dictionary(a.dictionary);
  std::printf("marker detection, %s, %d synthetic frames with 3 markers each (one thread)\n",
              a.dictionary.c_str(), a.frames);
  struct Case {
    const char* label;
    int width, height;
    CornerRefinement refine;
    bool aruco3;
    int frames;
  };
  const std::vector<Case> cases{
      {"640x480  subpixel (keyframe default)", 640, 480, CornerRefinement::kSubpixel, false,
       a.frames},
      {"640x480  edges", 640, 480, CornerRefinement::kEdgeLines, false, a.frames},
      {"640x480  subpixel + aruco3", 640, 480, CornerRefinement::kSubpixel, true, a.frames},
      {"2048x2048 edges (scan cube face)", 2048, 2048, CornerRefinement::kEdgeLines, false,
       std::max(5, a.frames / 20)},
  };
  cv::setNumThreads(1);
  for (const Case& c : cases) {
    PinholeCamera camera;
    camera.width = c.width;
    camera.height = c.height;
    camera.fx = camera.fy = 0.9 * c.width;
    camera.cx = 0.5 * (c.width - 1);
    camera.cy = 0.5 * (c.height - 1);
    std::mt19937 rng(7);
    std::vector<cv::Mat> frames;
    for (int i = 0; i < std::min(c.frames, 20); ++i)
      frames.push_back(bench_frame(camera, *dictionary, rng));
    const markers::MarkerDetector detector(
        {.dictionary = a.dictionary, .corner_refinement = c.refine, .aruco3 = c.aruco3});
    std::vector<double> ms, cpu_ms;
    std::size_t found = 0;
    for (int i = 0; i < c.frames; ++i) {
      const cv::Mat& frame = frames[static_cast<std::size_t>(i) % frames.size()];
      // Thread CPU time too: on a shared machine wall time also counts other jobs.
      const ThreadCpuStopwatch cpu_watch;
      const Stopwatch watch;
      found += detector.detect(frame).size();
      ms.push_back(watch.elapsed_ms());
      cpu_ms.push_back(cpu_watch.elapsed_ms());
    }
    const SampleStats s = summarize(ms);
    const SampleStats cpu = summarize(cpu_ms);
    std::printf(
        "  %-36s wall median %7.2f p99 %7.2f ms | cpu median %7.2f p99 %7.2f ms | %.2f/3 found\n",
        c.label, s.median, s.p99, cpu.median, cpu.p99, static_cast<double>(found) / c.frames);
  }
}

}  // namespace

void add_markers_verb(CLI::App& app, CLI::App& bench) {
  CLI::App& markers_cmd = *app.add_subcommand("markers", "ArUco / AprilTag markers in images");
  markers_cmd.require_subcommand(1);
  auto d = std::make_shared<DetectArgs>();
  CLI::App& det = *markers_cmd.add_subcommand(
      "detect", "Detect markers; with --size and --camera also their pose (camera_from_marker)");
  det.add_option("IMAGE", d->images, "Image files")->required()->check(CLI::ExistingFile);
  det.add_option("--dictionary", d->dictionary,
                 "DICT_4X4_50 ... DICT_APRILTAG_36h11, or a dictionary .yml")
      ->required();
  auto* size =
      det.add_option("--size", d->size, "Marker edge length (metres)")->check(CLI::PositiveNumber);
  auto* cam = det.add_option("--camera", d->camera, "Camera settings (ORB-SLAM3 YAML)")
                  ->check(CLI::ExistingFile);
  size->needs(cam);
  cam->needs(size);
  det.add_option("--refine", d->refine,
                 "Corner refinement: subpixel, edges, apriltag, contour, none")
      ->check(CLI::IsMember({"none", "subpixel", "contour", "apriltag", "edges"}))
      ->capture_default_str();
  det.add_option("--params", d->params, "OpenCV detector_params.yml");  // checked by its reader
  det.add_flag("--json", d->json, "Machine-readable output on stdout");
  det.callback([d] { detect(*d); });

  auto s = std::make_shared<ScanArgs>();
  CLI::App& scan = *app.add_subcommand(
      "scan-markers", "Global marker corners from an E57 scan's posed images -> marker map");
  scan.add_option("SCAN", s->scan, "E57 file")->required()->check(CLI::ExistingFile);
  scan.add_option("--dictionary", s->dictionary, "Marker dictionary")->required();
  scan.add_option("--size", s->size, "Marker edge length (metres)")
      ->required()
      ->check(CLI::PositiveNumber);
  scan.add_option("--out", s->out, "Marker map to write (.yaml or .json)")->required();
  scan.add_option("--debug", s->debug, "Write every searched image / cube face with detections");
  scan.add_option("--max-reprojection", s->max_reprojection,
                  "Reject detections above this reprojection error (pixels)")
      ->capture_default_str();
  scan.add_option("--max-distance", s->max_distance, "Reject markers farther than this (metres)")
      ->capture_default_str();
  scan.add_option("--face-size", s->face_size, "Cube face size for panoramas (pixels)")
      ->capture_default_str();
  scan.add_option("--refine", s->refine, "Corner refinement: edges, subpixel, apriltag, ...")
      ->check(CLI::IsMember({"none", "subpixel", "contour", "apriltag", "edges"}))
      ->capture_default_str();
  scan.add_option("--truth", s->truth, "Ground-truth corners (twin groundtruth/markers.txt)")
      ->check(CLI::ExistingFile);
  scan.add_flag("--json", s->json, "Machine-readable summary on stdout");
  scan.callback([s] { scan_markers_verb(*s); });

  auto b = std::make_shared<MarkerBenchArgs>();
  CLI::App& bm = *bench.add_subcommand(
      "markers", "Marker detection time per 640x480 keyframe and per 2048x2048 cube face");
  bm.add_option("--frames", b->frames, "Timed frames per case")->capture_default_str();
  bm.add_option("--dictionary", b->dictionary, "Marker dictionary")->capture_default_str();
  bm.callback([b] { bench_markers(*b); });
}

}  // namespace coloc::cli
