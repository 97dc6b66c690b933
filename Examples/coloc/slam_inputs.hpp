#pragma once
// What the SLAM verbs (coloc map, coloc bench track, coloc eval frame-limit) load: the camera
// settings (given, or the file shipped for the sequence's format), the sequence read with the
// settings' depth scale, and the vocabulary.
#include <filesystem>
#include <memory>

#include "slam/bow/vocabulary.hpp"
#include "slam/dataset/sequence.hpp"
#include "slam/settings/settings.hpp"

namespace coloc::cli {

struct SlamInputs {
  std::filesystem::path config;
  settings::Settings settings;
  std::unique_ptr<dataset::Sequence> sequence;
};

// Empty `config`: the sequence folder's camera.yaml (twin sequences), else the shipped
// settings/TUM1.yaml or settings/7Scenes.yaml (data_dir()) by the sequence's format.
SlamInputs load_slam_inputs(const std::filesystem::path& sequence,
                            const std::filesystem::path& config);

// The sequence read with the settings' depth scale (DepthMapFactor).
std::unique_ptr<dataset::Sequence> open_sequence_for(const std::filesystem::path& sequence,
                                                     const settings::Settings& settings);

// Empty `config`: the shipped file for the sequence's format (as load_slam_inputs picks it).
std::filesystem::path default_config_for(const std::filesystem::path& sequence);

// Empty path: the shipped vocabulary (data_dir()).
slam::bow::Vocabulary load_vocabulary(const std::filesystem::path& path);

}  // namespace coloc::cli
