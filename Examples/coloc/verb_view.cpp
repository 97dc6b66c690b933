// coloc view MAP.db: the map in the browser (slam/view): keyframes, points, covisibility and
// loop edges, marker corners seen by SLAM and (--markers) from the scan, the scan's points
// (--scan), keyframe images with their features (--sequence), and a registered map's residuals
// with the report's before/after figures (--report). Served on localhost until Ctrl-C.

#include <spdlog/spdlog.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <memory>
#include <regex>
#include <set>

#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/slam_inputs.hpp"
#include "Examples/coloc/verbs.hpp"
#include "Examples/coloc/view_session.hpp"
#include "markers/marker_map.hpp"
#include "registration/align/scan_cloud.hpp"
#include "registration/align/slam_markers.hpp"
#include "slam/core/error.hpp"
#include "slam/core/row_progress.hpp"
#include "slam/mapdb/mapdb.hpp"
#include "slam/view/scene.hpp"

namespace coloc::cli {
namespace {

namespace fs = std::filesystem;
namespace view = slam::view;

struct StaticViewArgs {
  fs::path map, scan, markers, report, sequence, vocabulary;
  double scan_voxel = 0.05;
  double seconds = -1.0;  // serve this long (< 0: until Ctrl-C)
  bool json = false;
  ViewArgs view;
};

// Marker corners as SLAM saw them; a map whose markers cannot be lifted is still shown.
std::vector<view::SceneMarker> slam_markers_of(const slam::mapdb::LoadedMap& loaded,
                                               const fs::path& file) {
  std::vector<view::SceneMarker> out;
  try {
    const auto corners =
        registration::align::slam_marker_corners(loaded.map, slam::mapdb::camera_of(loaded, file));
    for (const auto& [id, m] : corners.markers)
      out.push_back({id, m.corners});
  } catch (const Error& e) {
    spdlog::warn("marker corners of the map not shown: {}", e.what());
  }
  return out;
}

// u32 count, f32 xyz x count, u8 rgb x count (the page's /api/scan.bin).
std::string scan_binary(const fs::path& e57, double voxel) {
  registration::align::ScanCloudOptions options;
  options.voxel_size = voxel;
  registration::align::ScanCloudStats stats;
  RowProgress progress("reading the scan", false);
  const auto cloud =
      registration::align::load_scan_cloud(e57, options, &stats, progress.callback());
  progress.finish();
  const auto n = static_cast<std::uint32_t>(cloud.points.size());
  std::string out(4 + 15 * static_cast<std::size_t>(n), '\0');
  std::memcpy(out.data(), &n, 4);
  for (std::uint32_t i = 0; i < n; ++i) {
    std::memcpy(out.data() + 4 + 12 * static_cast<std::size_t>(i), cloud.points[i].data(), 12);
    std::memcpy(out.data() + 4 + 12 * static_cast<std::size_t>(n) + 3 * static_cast<std::size_t>(i),
                cloud.colours[i].data(), 3);
  }
  spdlog::info("scan: {} points read, {} shown ({} m voxels)", stats.points_read, n, voxel);
  return out;
}

// The registration summary (the map's metadata, else the report's registration.json) and the
// report's figures, paired by keyframe: {"registration": ..., "report": [{keyframe, markers,
// pointcloud}]}.
std::string registration_of(const slam::mapdb::MapMetadata& metadata, const fs::path& report) {
  Json reg;
  if (!metadata.registration.empty()) reg = Json::parse(metadata.registration, nullptr, false);
  Json figures = Json::array();
  if (!report.empty()) {
    if (reg.is_null() || reg.is_discarded()) {
      std::ifstream f(report / "registration.json");
      if (f) reg = Json::parse(f, nullptr, false);
    }
    std::set<std::uint64_t> ids;
    const std::regex name(R"(keyframe_(\d+)_markers\.png)");
    for (const auto& entry : fs::directory_iterator(report)) {
      std::smatch m;
      const std::string file = entry.path().filename().string();
      if (std::regex_match(file, m, name) &&
          fs::exists(report / ("keyframe_" + m[1].str() + "_pointcloud.png")))
        ids.insert(std::stoull(m[1].str()));
    }
    for (std::uint64_t id : ids) {
      const std::string k = std::to_string(id);
      figures.push_back({{"keyframe", id},
                         {"markers", "/report/keyframe_" + k + "_markers.png"},
                         {"pointcloud", "/report/keyframe_" + k + "_pointcloud.png"}});
    }
  }
  if (reg.is_discarded()) reg = nullptr;
  return Json{{"registration", reg}, {"report", figures}}.dump();
}

void run_view(const StaticViewArgs& a) {
  // Before any thread starts: Ctrl-C is then taken by wait_for_stop_signal, never by a server
  // thread.
  block_stop_signals();
  const slam::bow::Vocabulary vocabulary = load_vocabulary(a.vocabulary);
  slam::mapdb::LoadedMap loaded;
  {
    RowProgress progress("loading the map", a.json);
    loaded = slam::mapdb::load_map(
        a.map, vocabulary,
        {.rebuild_bow = false, .keyframe_depth = false, .progress = progress.callback()});
    progress.finish();
  }
  view::MapScene scene = view::scene_of(loaded.map);
  scene.frame = loaded.metadata.frame_name;
  scene.slam_markers = slam_markers_of(loaded, a.map);
  if (!a.markers.empty()) {
    for (const auto& [id, m] : markers::read_marker_map(a.markers).markers)
      scene.scan_markers.push_back({id, m.corners});
    view::add_marker_residuals(scene, loaded.map, slam::mapdb::camera_of(loaded, a.map));
  }
  const std::string scan = a.scan.empty() ? std::string() : scan_binary(a.scan, a.scan_voxel);
  std::unique_ptr<KeyframeImages> images;
  if (!a.sequence.empty()) images = std::make_unique<KeyframeImages>(a.sequence);

  const auto server = start_view_server(a.view, a.report, true);
  server->set_info(
      Json{{"mode", "saved map"}, {"map", a.map.filename().string()}, {"live", false}}.dump());
  server->set_scene(view::scene_json(scene, 1), 1);
  server->set_scan(scan);
  server->set_registration(registration_of(loaded.metadata, a.report));
  const slam::map::Map& map = loaded.map;  // read-only from here: the server threads share it
  server->set_keyframe_source([&map](std::uint64_t id) { return view::keyframe_json(map, id); });
  if (images) {
    server->set_keyframe_image_source(
        [&map, &images](std::uint64_t id) -> std::optional<std::string> {
          const auto* kf = map.keyframe(KeyframeId(id));
          return kf ? images->jpeg(kf->frame.timestamp) : std::nullopt;
        });
  }
  if (a.json) {
    print_json({{"url", server->url()},
                {"port", server->port()},
                {"keyframes", scene.keyframes.size()},
                {"map_points", scene.points.positions.size()},
                {"slam_markers", scene.slam_markers.size()},
                {"scan_markers", scene.scan_markers.size()},
                {"scan_points", scan.empty() ? 0 : (scan.size() - 4) / 15}});
  } else {
    std::cout << "viewer at " << server->url() << " (" << scene.keyframes.size() << " keyframes, "
              << scene.points.positions.size() << " points); Ctrl-C to stop" << std::endl;
  }
  std::fflush(stdout);
  wait_for_stop_signal(a.seconds);
  server->stop();
  const auto s = server->stats();
  spdlog::info("viewer stopped: {} requests, {} pages ({} disconnected)", s.requests,
               s.clients_connected, s.disconnected);
}

}  // namespace

void add_view_verb(CLI::App& app, CLI::App& bench) {
  auto a = std::make_shared<StaticViewArgs>();
  CLI::App* cmd = app.add_subcommand("view", "Show a saved map in the browser (localhost)");
  cmd->add_option("map", a->map, "Map file (coloc map --save, coloc register)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--scan", a->scan, "The laser scan (E57): its points, thinned")
      ->check(CLI::ExistingFile);
  cmd->add_option("--scan-voxel", a->scan_voxel, "Voxel size of the shown scan points (metres)")
      ->check(CLI::PositiveNumber);
  // Checked by the marker map's reader (a directory or FIFO is named there, exit 1).
  cmd->add_option("--markers", a->markers, "Marker map of the scan (coloc scan-markers)");
  cmd->add_option("--report", a->report, "Registration report folder (coloc register --report)")
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--sequence", a->sequence, "The mapped sequence: keyframe images")
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--vocabulary", a->vocabulary, "BoW vocabulary the map was built with");
  cmd->add_option("--port", a->view.port, "Port (0: any free port)")->check(CLI::Range(0, 65535));
  cmd->add_option("--bind", a->view.bind, "Address (127.0.0.1: this machine only)");
  cmd->add_option("--web-root", a->view.web_root, "The page's folder (default: the built one)");
  cmd->add_option("--seconds", a->seconds, "Serve this long, then exit (default: until Ctrl-C)");
  cmd->add_flag("--json", a->json, "Print the address and counts as JSON");
  cmd->callback([a] { run_view(*a); });
  add_view_bench_verb(bench);
}

}  // namespace coloc::cli
