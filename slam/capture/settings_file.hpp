#pragma once
// Camera settings files coloc writes (the recorder's camera.yaml, `coloc calibrate --out`): the
// ORB-SLAM3 v1.0 format that `coloc map` and ORB-SLAM3 read unchanged.
#include <filesystem>
#include <string>

#include "slam/core/camera.hpp"

namespace coloc::capture {

struct SettingsFileContent {
  PinholeCamera camera;
  double fps = 30.0;
  bool rgb = true;                // Camera.RGB
  double depth_map_factor = 0.0;  // RGBD.DepthMapFactor (0: no depth keys)
  double baseline_m = 0.0;        // Stereo.b (with depth)
  std::string comment;            // a "# ..." header saying where the numbers came from
};

// Writes `content` to `path` under a temporary name, renamed when complete. Throws coloc::Error
// naming the file.
void write_settings_file(const std::filesystem::path& path, const SettingsFileContent& content);

// Writes `text` to `path` through `<path>.tmp` and a rename. Throws coloc::Error naming it.
void write_file_atomically(const std::filesystem::path& path, const std::string& text);

}  // namespace coloc::capture
