#pragma once
// Plots for the CLI, drawn by matplotlib (Agg backend, headless): the verb describes panels of
// line series here, write_plot() hands that description as JSON to Examples/coloc/plot.py
// (run with the python3 found at configure time) and renames the finished file into place.

#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <vector>

namespace coloc::cli {

struct Series {
  std::string label;                    // legend entry
  std::vector<Eigen::Vector2d> points;  // (x, y) in the panel's units, drawn as one line
  std::string colour;                   // matplotlib colour ("tab:blue", "#3c3c3c"); empty: cycle
};

struct Panel {
  std::string title;
  std::string x_label;
  std::string y_label;
  bool equal_aspect = false;  // true for top views (metres on both axes)
  std::vector<Series> series;
};

// Throws coloc::Error naming `path` unless a plot can be written there: a .png/.pdf/.svg name
// in an existing, writable folder, and not a folder or an unwritable file itself. Verbs call it
// before their work so a typo does not cost a long run.
void check_plot_path(const std::filesystem::path& path);

// Draws the panels side by side into one image at `path` (format from the extension). The file
// is written under a temporary name and renamed when complete, so `path` never holds half a
// plot. Throws coloc::Error when python3 or matplotlib is missing or the script fails (with
// its message).
void write_plot(const std::filesystem::path& path, const std::vector<Panel>& panels);

}  // namespace coloc::cli
