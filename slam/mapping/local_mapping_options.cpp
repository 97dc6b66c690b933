// LocalMappingOptions::check in an object of its own: what reads the options (the tuning table,
// and through it the localizer) links this, not the local mapper.
#include "slam/core/error.hpp"
#include "slam/mapping/local_mapper.hpp"

namespace coloc::slam::mapping {

void LocalMappingOptions::check() const {
  if (queue_capacity < 1) throw Error("LocalMappingOptions.queue_capacity must be >= 1");
  if (!(fusion_radius > 0.0)) throw Error("LocalMappingOptions.fusion_radius must be > 0");
  if (!(redundancy > 0.0 && redundancy <= 1.0))
    throw Error("LocalMappingOptions.redundancy must be in (0, 1]");
  if (!(redundancy_straight > 0.0 && redundancy_straight <= 1.0))
    throw Error("LocalMappingOptions.redundancy_straight must be in (0, 1]");
  if (!(straight_turn_deg >= 0.0 && straight_turn_deg <= 180.0))
    throw Error("LocalMappingOptions.straight_turn_deg must be in [0, 180]");
  if (!(readout_step > 0.0)) throw Error("LocalMappingOptions.readout_step must be > 0");
  if (!(readout_publish >= 0.0)) throw Error("LocalMappingOptions.readout_publish must be >= 0");
  if (!(readout_max > 0.0 && readout_max < 1.0))
    throw Error("LocalMappingOptions.readout_max must be in (0, 1) seconds");
  if (!(readout_start >= 0.0 && readout_start <= 1.0))
    throw Error(
        "LocalMappingOptions.readout_start must be in [0, 1] (a share of the frame interval)");
  ba.check();
}

}  // namespace coloc::slam::mapping
