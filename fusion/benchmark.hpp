#pragma once
// Figures for `coloc bench fusion` (DESIGN.md section 5): accuracy of the compared methods on
// the simulated session, the cost of one fused pose, and the OSC loopback round trip. Speed is
// measured here and printed by the CLI, never asserted in tests.

#include <string>
#include <vector>

#include "fusion/simulation.hpp"
#include "slam/core/timing.hpp"

namespace coloc::fusion {

struct MethodResult {
  std::string name;
  ErrorMetrics metrics;
};

// raw headset, snap to every global pose, the paper's filter, ours (time alignment + gating),
// ours with a 5 cm/s, 3 deg/s correction rate limit.
std::vector<MethodResult> compare_methods(const SimulatedSession& session);

// Microseconds per fused pose (DriftFuser::push_xr_pose with time alignment on a full buffer),
// one sample per batch of `batch` calls.
SampleStats time_fused_pose(int batches = 200, int batch = 1000);

// Microseconds per OSC round trip on loopback: a client sends /coloc/get_pose to a PoseServer
// (its own thread) and waits for the /coloc/pose reply. Throws coloc::Error if a reply does not
// come within a second.
SampleStats time_osc_round_trip(int round_trips = 2000);

}  // namespace coloc::fusion
