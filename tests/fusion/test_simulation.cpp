#include <gtest/gtest.h>

#include <numbers>

#include "fusion/simulation.hpp"
#include "tests/testing/data.hpp"

namespace coloc::fusion {
namespace {

struct Results {
  ErrorMetrics raw, snap, paper, ours;
};

Results run(const SessionOptions& options) {
  const SimulatedSession s = simulate_session(options);
  return {evaluate_trajectory(raw_headset(s), s.truth),
          evaluate_trajectory(replay_session(s, snap_options()), s.truth),
          evaluate_trajectory(replay_session(s, paper_options()), s.truth),
          evaluate_trajectory(replay_session(s, ours_options()), s.truth)};
}

TEST(Simulation, SessionHasTheRequestedShape) {
  SessionOptions options;
  options.duration = 30.0;
  const SimulatedSession s = simulate_session(options);
  EXPECT_EQ(s.truth.size(), 2700u);
  EXPECT_EQ(s.headset.size(), s.truth.size());
  EXPECT_NEAR(static_cast<double>(s.global.size()), 30.0 * 20.0, 2.0);
  for (const GlobalSample& g : s.global)
    EXPECT_NEAR(g.arrival_time - g.exposure_time, 0.05, 1e-12);
  // Walking speed ~1.2 m/s on average.
  double length = 0.0;
  for (std::size_t i = 1; i < s.truth.size(); ++i) {
    length += translation_distance(s.truth[i].world_from_cam, s.truth[i - 1].world_from_cam);
  }
  EXPECT_NEAR(length / 30.0, 1.2, 0.3);
  // Same seed, same session.
  const SimulatedSession again = simulate_session(options);
  EXPECT_EQ(again.global[100].world_from_head.translation(),
            s.global[100].world_from_head.translation());
}

// The acceptance test of the fusion (fixed seed): fused error below the raw headset's, smoother
// than snapping to global poses, and time alignment + gating beat the paper's filter.
TEST(Simulation, FusionBeatsRawHeadsetAndIsSmootherThanGlobalPoses) {
  for (const double rate : {15.0, 20.0, 60.0}) {
    SessionOptions options;
    options.global_rate = rate;
    options.seed = 11;
    const Results r = run(options);
    SCOPED_TRACE(rate);
    EXPECT_LT(r.ours.position_rmse, 0.5 * r.raw.position_rmse);
    EXPECT_LT(r.ours.rotation_rmse, r.raw.rotation_rmse);
    EXPECT_LT(r.ours.position_rmse, r.paper.position_rmse);
    EXPECT_LT(r.ours.position_p95, r.paper.position_p95);
    EXPECT_LT(r.ours.position_rmse, 0.05);  // a few cm in a drifting 2-minute walk
    EXPECT_LT(r.ours.rotation_rmse, std::numbers::pi / 180.0);
    // Smoothness: snapping jumps by the global noise (cm) at every pose; the fused poses by
    // far less.
    EXPECT_LT(r.ours.jitter_position_p99, 0.25 * r.snap.jitter_position_p99);
    EXPECT_LT(r.ours.jitter_rotation_p99, 0.5 * r.snap.jitter_rotation_p99);
  }
}

TEST(Simulation, StaticViveLogGivesSubMillimetreNoise) {
  COLOC_REQUIRE_DATA(dir, "vive_tracker_vs_lasertracker/20201002_Exp1_Drift");
  const StaticLogStats s = analyze_static_drift_log(dir / "drift20minExperiment.txt");
  EXPECT_EQ(s.samples, 6001u);
  EXPECT_GT(s.position_noise, 0.0001);
  EXPECT_LT(s.position_noise, 0.001);
  EXPECT_LT(s.wander, 0.005);  // lighthouse tracking barely drifts when static
  EXPECT_GT(s.wander, s.position_noise * 0.5);
}

}  // namespace
}  // namespace coloc::fusion
