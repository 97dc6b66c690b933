#include "Examples/coloc/slam_inputs.hpp"

#include "Examples/coloc/cli_common.hpp"
#include "slam/core/error.hpp"

namespace coloc::cli {

namespace fs = std::filesystem;

namespace {

// The sequence's own camera.yaml (the twin writes one), else the shipped camera file for the
// sequence's format.
fs::path default_config(const dataset::Sequence& sequence) {
  if (fs::is_regular_file(sequence.folder() / "camera.yaml"))
    return sequence.folder() / "camera.yaml";
  if (sequence.format() == "7scenes") return data_file("settings/7Scenes.yaml");
  if (sequence.format() == "tum") return data_file("settings/TUM1.yaml");
  throw Error("no default camera settings for format '" + sequence.format() + "': pass --config");
}

}  // namespace

fs::path default_config_for(const fs::path& sequence) {
  return default_config(*dataset::open_sequence(sequence));
}

std::unique_ptr<dataset::Sequence> open_sequence_for(const fs::path& sequence,
                                                     const settings::Settings& settings) {
  // The settings file's DepthMapFactor says how raw depth becomes metres (TUM 5000 per metre,
  // RealSense and the twin 1000): the sequence is read with it, not with the format's default.
  dataset::SequenceOptions options;
  if (settings.depth) options.depth_scale = settings.depth->depth_map_factor;
  return dataset::open_sequence(sequence, options);
}

SlamInputs load_slam_inputs(const fs::path& sequence, const fs::path& config) {
  SlamInputs in;
  in.config = config.empty() ? default_config_for(sequence) : config;
  in.settings = settings::load_settings(in.config);
  in.sequence = open_sequence_for(sequence, in.settings);
  return in;
}

slam::bow::Vocabulary load_vocabulary(const fs::path& path) {
  return slam::bow::Vocabulary::load(path.empty() ? shipped_vocabulary() : path);
}

}  // namespace coloc::cli
