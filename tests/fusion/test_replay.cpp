#include <gtest/gtest.h>

#include "fusion/replay.hpp"
#include "fusion/simulation.hpp"

namespace coloc::fusion {
namespace {

// `coloc fuse --xr --global --latency` on recorded files is the simulated session's replay:
// the global poses written as a TUM trajectory and delivered `latency` later fuse identically.
TEST(Replay, RecordedFilesFuseLikeTheSimulatedSession) {
  SessionOptions options;
  options.duration = 20.0;
  options.global_latency = 0.07;
  const SimulatedSession session = simulate_session(options);
  Trajectory global;
  for (const GlobalSample& g : session.global)
    global.push_back({g.exposure_time, g.world_from_head});
  const HeadsetReplay recorded =
      replay_headset(session.headset, delayed(global, options.global_latency), ours_options());
  const Trajectory simulated = replay_session(session, ours_options());
  ASSERT_EQ(recorded.fused.size(), simulated.size());
  for (std::size_t i = 0; i < simulated.size(); ++i) {
    EXPECT_EQ(recorded.fused[i].timestamp, simulated[i].timestamp);
    EXPECT_TRUE(recorded.fused[i].world_from_cam.matrix() == simulated[i].world_from_cam.matrix())
        << "pose " << i;
  }
  EXPECT_EQ(recorded.stats.xr_poses, session.headset.size());
  EXPECT_GT(recorded.stats.accepted, recorded.stats.global_poses / 2);
}

// IMU mode: a level IMU at rest, global poses of a fixed body pose from t = 1 s arriving 50 ms
// late. Nothing is output before the first global pose has arrived (the integrator is not yet
// in the world frame); afterwards the output holds the global pose.
TEST(Replay, ImuOutputStartsAtAnchoringAndFollowsTheGlobalPoses) {
  std::vector<ImuSample> imu;
  for (int i = 0; i < 600; ++i)  // 3 s at 200 Hz
    imu.push_back({0.005 * i, Eigen::Vector3d::Zero(), Eigen::Vector3d(0.0, 0.0, 9.81)});
  const SE3 world_from_body(SO3(), Eigen::Vector3d(1.0, 2.0, 0.5));
  Trajectory global;
  for (int k = 0; k < 40; ++k)  // 20 Hz from t = 1 s
    global.push_back({1.0 + 0.05 * k, world_from_body});
  const ImuReplay r = replay_imu(imu, delayed(global, 0.05), {});
  ASSERT_FALSE(r.fused.empty());
  EXPECT_GE(r.fused.front().timestamp, 1.05 - 1e-9);
  EXPECT_EQ(r.imu.imu_samples, imu.size());
  EXPECT_GT(r.fuser.accepted, 0u);
  EXPECT_LT((r.fused.back().world_from_cam.translation() - world_from_body.translation()).norm(),
            0.01);
}

}  // namespace
}  // namespace coloc::fusion
