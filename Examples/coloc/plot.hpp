#pragma once
// Small PNG plots for the CLI (OpenCV drawing): line series in a panel with axes and a legend.

#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <vector>

namespace coloc::cli {

struct Series {
  std::string label;
  std::vector<Eigen::Vector2d> points;
  Eigen::Vector3i bgr{0, 0, 0};
};

struct Panel {
  std::string title;
  std::string x_label;
  std::string y_label;
  bool equal_aspect = false;  // true for top views (metres on both axes)
  std::vector<Series> series;
};

// Draws the panels side by side into one PNG. Throws coloc::Error when it cannot be written.
void write_plot(const std::filesystem::path& path, const std::vector<Panel>& panels);

}  // namespace coloc::cli
