#pragma once
// Options of the SLAM system: tracking's and local mapping's, and what the system adds.
#include <string>

#include "slam/mapping/local_mapper.hpp"
#include "slam/tracking/tracker.hpp"

namespace coloc::slam::system {

struct SystemOptions {
  tracking::TrackingOptions tracking;
  mapping::LocalMappingOptions mapping;
  bool detect_markers = true;  // run the marker detector on every keyframe
  // Throws coloc::Error naming the first invalid field.
  void check() const;
  // The effective values, one per line (logged at start).
  std::string describe() const;
};

}  // namespace coloc::slam::system
