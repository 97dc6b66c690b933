// rgbd_tum VOCABULARY SETTINGS SEQUENCE ASSOCIATIONS
// ORB-SLAM3's RGB-D TUM example with its argument order and output files: reads the
// associations file ("t_rgb rgb/x.png t_depth depth/y.png" per line, as TUM's associate.py
// writes), runs coloc's RGB-D SLAM, and writes CameraTrajectory.txt and KeyFrameTrajectory.txt
// (TUM format) in the working directory. ORB-SLAM3 v1.0's System.LoadAtlasFromFile continues a
// saved map (coloc's map database, ".db" added to a bare name) and System.SaveAtlasToFile saves
// the map at the end. Exit code 0 on success, 1 on failure, 2 on bad usage.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "slam/core/atomic_file.hpp"
#include "slam/core/error.hpp"
#include "slam/core/input_file.hpp"
#include "slam/core/trajectory.hpp"
#include "slam/dataset/sequence.hpp"
#include "slam/settings/settings.hpp"
#include "slam/system/system.hpp"

namespace {

struct Entry {
  double timestamp = 0.0;
  std::string rgb, depth;
};

std::vector<Entry> read_associations(const std::filesystem::path& path) {
  coloc::check_input_file(path, "associations file");
  std::ifstream in(path);
  if (!in) throw coloc::Error("cannot open associations file", {path.string()});
  std::vector<Entry> entries;
  std::string line;
  std::int64_t number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream s(line);
    Entry e;
    double t_depth = 0.0;
    if (!(s >> e.timestamp >> e.rgb >> t_depth >> e.depth)) {
      throw coloc::Error("expected 't_rgb rgb_path t_depth depth_path'",
                         {path.string(), "", std::nullopt, number});
    }
    entries.push_back(e);
  }
  return entries;
}

int run(int argc, char** argv) {
  if (argc != 5) {
    std::cerr << "usage: rgbd_tum VOCABULARY SETTINGS SEQUENCE ASSOCIATIONS\n";
    return 2;
  }
  const std::filesystem::path sequence = argv[3];
  const auto vocabulary = coloc::slam::bow::Vocabulary::load(argv[1]);
  const auto settings = coloc::settings::load_settings(argv[2]);
  const auto entries = read_associations(argv[4]);
  if (entries.empty()) throw coloc::Error("no frames in the associations file", {argv[4]});
  const double depth_factor = settings.depth ? settings.depth->depth_map_factor : 5000.0;
  // An unwritable map destination is an error before the run, not after it.
  if (!settings.save_map.empty()) coloc::AtomicFile probe(settings.save_map);
  const auto system = coloc::slam::system::open_system(settings, vocabulary, {}, settings.load_map);
  auto& slam = *system;
  for (const Entry& e : entries) {
    const cv::Mat color = coloc::dataset::to_camera_order(
        coloc::dataset::read_image(sequence / e.rgb), settings.rgb_order);
    const cv::Mat depth = coloc::dataset::read_depth(sequence / e.depth, depth_factor);
    slam.track(color, depth, e.timestamp);
  }
  slam.shutdown();
  if (!settings.save_map.empty()) {
    const auto report = slam.save_map(settings.save_map);
    std::cerr << "map saved to " << settings.save_map.string() << ": " << report.keyframes
              << " keyframes, " << report.points << " points\n";
  }
  coloc::write_tum_trajectory("CameraTrajectory.txt", slam.trajectory());
  coloc::write_tum_trajectory("KeyFrameTrajectory.txt", slam.keyframe_trajectory());
  std::cerr << slam.summary().describe() << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  spdlog::set_default_logger(spdlog::stderr_color_mt("rgbd_tum"));
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << '\n';
    return 1;
  }
}
