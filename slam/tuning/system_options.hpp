#pragma once
// Options of the SLAM system: tracking's, local mapping's and loop closing's, and what the
// system adds.
#include <string>

#include "slam/loop/loop_options.hpp"
#include "slam/mapping/local_mapper.hpp"
#include "slam/tracking/tracker.hpp"

namespace coloc::slam::system {

struct SystemOptions {
  tracking::TrackingOptions tracking;
  mapping::LocalMappingOptions mapping;
  loop::LoopOptions loop;      // loop.enabled = false: no loop closer behind local mapping
  bool detect_markers = true;  // run the marker detector on every keyframe
  // Throws coloc::Error naming the first invalid field.
  void check() const;
  // The effective values, one per line (logged at start).
  std::string describe() const;
};

}  // namespace coloc::slam::system
