#pragma once
// Fusion of several sightings of one marker (from different scanner images) into one set of
// global corners: a robust mean with outliers dropped and the residual reported.
//
// Ambiguity (marker_pose.hpp): a sighting whose IPPE pose was ambiguous brings both candidate
// corner sets. The fusion picks, per sighting, the candidate that agrees with the others: the
// seed is the candidate with the most support (smallest truncated distance to the other
// sightings), then each sighting takes its candidate nearest the seed. A lone ambiguous sighting
// keeps its smaller-error candidate and is counted as ambiguous in the map.

#include <array>
#include <map>
#include <string>
#include <vector>

#include "markers/marker_map.hpp"

namespace coloc::markers {

// One marker seen in one image, already in the global frame.
struct Sighting {
  int id = -1;
  std::string image;                             // name of the image (and cube face) it was seen in
  std::array<Eigen::Vector3d, 4> corners{};      // global frame, best IPPE candidate
  std::array<Eigen::Vector3d, 4> alternative{};  // global frame, the other candidate
  bool ambiguous = false;
  double reprojection_error_px = 0.0;
  double distance = 0.0;  // camera centre to marker centre, metres
  double edge_length = 0.0;
};

struct FusionOptions {
  // A sighting is an inlier when its RMS corner distance to the robust centre is below
  // max(min_gate, mad_factor * 1.4826 * MAD) (MAD: median absolute deviation of the distances).
  double min_gate = 0.01;  // metres
  double mad_factor = 3.0;
  // Sightings are weighted by 1 / max(distance, min_weight_distance)^2: corner noise in metres
  // grows with range.
  double min_weight_distance = 0.5;

  // Throws coloc::Error naming the first bad field.
  void check() const;
};

// RMS distance between corresponding corners, metres.
double corner_rms(const std::array<Eigen::Vector3d, 4>& a, const std::array<Eigen::Vector3d, 4>& b);

// Fuses the sightings of ONE marker id (all sightings must share it; throws coloc::Error
// otherwise, or when empty).
MapMarker fuse_sightings(const std::vector<Sighting>& sightings, const FusionOptions& options);

// Groups by id and fuses each; returns markers by id.
std::map<int, MapMarker> fuse_all(const std::vector<Sighting>& sightings,
                                  const FusionOptions& options);

}  // namespace coloc::markers
