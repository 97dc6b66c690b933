#pragma once
// The marker map: the global corner positions of every marker found in a laser scan, the ground
// truth that registration pulls the SLAM map onto. Written by `coloc scan-markers`, read by
// registration. The file format (YAML in OpenCV's %YAML:1.0 dialect, or JSON when the name ends
// in .json) is documented in README.md, section "Marker map file".

#include <Eigen/Core>
#include <array>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace coloc::markers {

struct MapMarker {
  int id = -1;
  // Corners in the map's frame (metres), in the detector's corner order (detector.hpp): the
  // marker's top-left, top-right, bottom-right, bottom-left.
  std::array<Eigen::Vector3d, 4> corners{};
  double edge_length = 0.0;     // metres, as given to PnP
  int sightings = 0;            // sightings fused into `corners`
  int rejected_sightings = 0;   // sightings dropped as outliers
  int ambiguous_sightings = 0;  // fused sightings whose pose had two plausible IPPE solutions
  // RMS distance (metres) between the fused sightings' corners and `corners`; 0 for one sighting.
  double residual = 0.0;
  std::vector<std::string> images;  // the images whose sightings were fused

  Eigen::Vector3d centre() const;
  // Unit normal of the printed face (pointing out of it), from the corner order.
  Eigen::Vector3d normal() const;
};

struct MarkerMap {
  std::string dictionary;            // the dictionary the ids belong to
  std::string frame = "global";      // the frame of the corners (the scan's file-level frame)
  std::string source;                // the scan file the markers came from
  std::vector<std::string> images;   // every image that was searched
  std::map<int, MapMarker> markers;  // by id
};

// Throws coloc::Error naming the file when it cannot be written.
void write_marker_map(const std::filesystem::path& path, const MarkerMap& map);

// Throws coloc::Error naming the file and the field (e.g. "markers[2].corners") for unreadable
// files, unknown keys, missing required keys, wrong types or duplicate ids.
MarkerMap read_marker_map(const std::filesystem::path& path);

}  // namespace coloc::markers
