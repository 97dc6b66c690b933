#pragma once
// A seeded synthetic XR session for tests and `coloc bench fusion` (COLMAP habit: the scene
// generator lives in the library). A head walks a figure-eight through a 16 x 8 m hall at
// ~1.2 m/s while looking around; the headset reports it through a slowly drifting frame; the
// localizer reports it at 15-60 Hz with noise, latency and gross outliers.
//
// Drift model: world_from_xr(t) starts at a random alignment and then drifts by a bias (constant
// velocity / yaw rate) plus a random walk; headset poses also get white noise. The white noise
// defaults come from the 20-minute static Vive log ($COLOC_DATA/vive_tracker_vs_lasertracker,
// see analyze_static_drift_log); that log's slow wander (~1 mm in 20 min, lighthouse tracking)
// is far below inside-out drift while walking, so the drift rates default to inside-out figures
// (a few mm/s, ~0.05 deg/s: metres and degrees after several minutes, the paper's problem).

#include <cstdint>
#include <filesystem>
#include <vector>

#include "fusion/fuser.hpp"
#include "fusion/replay.hpp"  // GlobalSample
#include "slam/core/trajectory.hpp"

namespace coloc::fusion {

struct HeadsetDriftModel {
  double position_noise = 0.0004;       // m, white, per headset sample (Vive log: ~0.4 mm)
  double rotation_noise = 0.0002;       // rad, white, per headset sample
  double position_random_walk = 0.003;  // m / sqrt(s)
  double position_bias = 0.003;         // m/s, constant drift velocity (random direction, xy)
  double yaw_random_walk = 0.0005;      // rad / sqrt(s)
  double yaw_bias = 0.001;              // rad/s (~0.06 deg/s)
  double tilt_random_walk = 0.0001;     // rad / sqrt(s), roll and pitch (gravity keeps it small)
};

struct SessionOptions {
  double duration = 120.0;               // s
  double headset_rate = 90.0;            // Hz
  double global_rate = 20.0;             // Hz
  double global_latency = 0.05;          // s from exposure to arrival
  double global_position_sigma = 0.015;  // m
  double global_rotation_sigma = 0.005;  // rad (~0.3 deg)
  double outlier_fraction = 0.02;
  double outlier_position = 0.5;   // m, typical size of a gross error (0.5x..1.5x)
  double outlier_rotation = 0.17;  // rad (~10 deg)
  HeadsetDriftModel drift;
  std::uint32_t seed = 1;

  void check() const;  // throws coloc::Error naming the field
};

struct SimulatedSession {
  Trajectory truth;    // world_from_head at the headset's sample times
  Trajectory headset;  // xr_from_head at the same times
  std::vector<GlobalSample> global;
  SE3 initial_world_from_xr;  // the true alignment at t = 0
};

SimulatedSession simulate_session(const SessionOptions& options);

// The true head pose of the simulated walk at any time (world_from_head).
SE3 simulated_head_pose(double time);

// Feeds the session to a DriftFuser in arrival order (replay_headset); returns one fused pose per
// headset sample.
Trajectory replay_session(const SimulatedSession& session, const FuserOptions& options);
// The same into a given fuser (e.g. to warm it up before timing it).
Trajectory replay_session(const SimulatedSession& session, DriftFuser& fuser);
// The headset with only the initial true alignment (what the user sees without fusion).
Trajectory raw_headset(const SimulatedSession& session);

// Fuser options of the compared methods: snapping to every global pose (gain ~1, no gate, no
// alignment), the paper's filter (Q 0.001, R 0.9, newest headset pose), ours (paper's Q/R with
// time alignment and gating).
FuserOptions snap_options();
FuserOptions paper_options();
FuserOptions ours_options();

struct ErrorMetrics {
  double position_rmse = 0.0;        // m
  double position_p95 = 0.0;         // m
  double rotation_rmse = 0.0;        // rad
  double rotation_p95 = 0.0;         // rad
  double jitter_position_p99 = 0.0;  // m: frame-to-frame jump beyond the true motion
  double jitter_rotation_p99 = 0.0;  // rad
};

// Compares estimate[i] with truth[i] (same times), skipping the first skip_seconds.
ErrorMetrics evaluate_trajectory(const Trajectory& estimate, const Trajectory& truth,
                                 double skip_seconds = 2.0);

// Statistics of a static tracker log in the vive_tracker_vs_lasertracker format (one 3x4 pose
// per line, row-major, metres; '#' comments).
struct StaticLogStats {
  std::size_t samples = 0;
  double rate = 5.0;            // Hz (the log's header says 5 Hz)
  double position_noise = 0.0;  // m, white noise per sample (from frame-to-frame steps)
  double wander = 0.0;          // m, largest distance of a 1-minute mean from the first
  double random_walk = 0.0;     // m/sqrt(s), wander / sqrt(duration) (order of magnitude)
};
// Throws coloc::Error naming the file and line on malformed input.
StaticLogStats analyze_static_drift_log(const std::filesystem::path& path, double rate = 5.0);

}  // namespace coloc::fusion
