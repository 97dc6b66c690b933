// rgbd_tum VOCABULARY SETTINGS SEQUENCE ASSOCIATIONS
// ORB-SLAM3's RGB-D TUM example with its argument order and output files: reads the
// associations file ("t_rgb rgb/x.png t_depth depth/y.png" per line, as TUM's associate.py
// writes), runs coloc's SLAM pipeline (the same call as `coloc map`: tracking, local mapping,
// loop closing, the final global BA), and writes CameraTrajectory.txt and KeyFrameTrajectory.txt
// (TUM format) in the working directory. With a groundtruth.txt in SEQUENCE it also prints the
// ATE. ORB-SLAM3 v1.0's System.LoadAtlasFromFile continues a saved map (coloc's map database,
// ".db" added to a bare name) and System.SaveAtlasToFile saves the map at the end. Exit code 0
// on success, 1 on failure, 2 on bad usage.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <filesystem>
#include <iostream>

#include "slam/core/atomic_file.hpp"
#include "slam/core/trajectory.hpp"
#include "slam/dataset/sequence.hpp"
#include "slam/pipeline/pipeline.hpp"
#include "slam/settings/settings.hpp"

namespace {

int run(int argc, char** argv) {
  if (argc != 5) {
    std::cerr << "usage: rgbd_tum VOCABULARY SETTINGS SEQUENCE ASSOCIATIONS\n";
    return 2;
  }
  const auto vocabulary = coloc::slam::bow::Vocabulary::load(argv[1]);
  const auto settings = coloc::settings::load_settings(argv[2]);
  coloc::dataset::SequenceOptions sequence_options{.associations = argv[4]};
  if (settings.depth) sequence_options.depth_scale = settings.depth->depth_map_factor;
  const auto sequence = coloc::dataset::open_tum(argv[3], sequence_options);
  // Unwritable destinations are errors before the run, not after it.
  if (!settings.save_map.empty()) coloc::AtomicFile probe(settings.save_map);
  { const coloc::AtomicFile probe("CameraTrajectory.txt"); }
  { const coloc::AtomicFile probe("KeyFrameTrajectory.txt"); }
  const auto result = coloc::slam::pipeline::run_slam(
      *sequence, settings, vocabulary, {.load = settings.load_map},
      [&](const coloc::slam::system::System& slam) {
        if (settings.save_map.empty()) return;
        const auto report = slam.save_map(settings.save_map);
        std::cerr << "map saved to " << settings.save_map.string() << ": " << report.keyframes
                  << " keyframes, " << report.points << " points\n";
      });
  coloc::write_tum_trajectory("CameraTrajectory.txt", result.trajectory);
  coloc::write_tum_trajectory("KeyFrameTrajectory.txt", result.keyframes);
  std::cerr << result.summary.describe() << "\n";
  if (result.ate) std::cerr << "ATE rmse " << result.ate->translation.rmse << " m\n";
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
