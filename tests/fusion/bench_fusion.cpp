// Google Benchmark for fusion (DESIGN.md targets: one compensated pose < 2 us, OSC loopback
// round trip < 200 us median). Run: build/tests/fusion/bench_fusion

#include <benchmark/benchmark.h>

#include "fusion/osc.hpp"
#include "fusion/osc_endpoint.hpp"
#include "fusion/osc_node.hpp"
#include "fusion/simulation.hpp"

namespace coloc::fusion {
namespace {

// A fuser that has seen 10 s of a session: full headset buffer, initialized filter.
DriftFuser warm_fuser(const FuserOptions& options, double& t) {
  SessionOptions session;
  session.duration = 10.0;
  const SimulatedSession s = simulate_session(session);
  DriftFuser fuser(options);
  replay_session(s, fuser);
  t = s.headset.back().timestamp;
  return fuser;
}

void BM_FusedPose(benchmark::State& state) {
  FuserOptions options = ours_options();
  if (state.range(0) != 0) {
    options.max_correction_speed = 0.05;
    options.max_correction_rate = 0.05;
  }
  double t = 0.0;
  DriftFuser fuser = warm_fuser(options, t);
  const SE3 pose = simulated_head_pose(1.0);
  for (auto _ : state) {
    t += 1.0 / 90.0;
    benchmark::DoNotOptimize(fuser.push_xr_pose(t, pose));
  }
}
BENCHMARK(BM_FusedPose)->Arg(0)->Arg(1)->ArgName("rate_limit");

void BM_GlobalPoseUpdate(benchmark::State& state) {
  double t = 0.0;
  DriftFuser fuser = warm_fuser(ours_options(), t);
  // Re-push headset samples so each global pose finds an aligned headset pose.
  const SE3 pose = simulated_head_pose(1.0);
  for (auto _ : state) {
    t += 1.0 / 90.0;
    fuser.push_xr_pose(t, pose);
    benchmark::DoNotOptimize(fuser.push_global_pose(t - 0.005, pose));
  }
}
BENCHMARK(BM_GlobalPoseUpdate);

void BM_OscEncodeDecode(benchmark::State& state) {
  PoseMessage p = PoseMessage::from_pose(1.0, 1, 1, simulated_head_pose(2.0));
  for (auto _ : state) {
    const auto bytes = encode_pose(kPoseAddress, p);
    benchmark::DoNotOptimize(decode_packet(bytes.data(), bytes.size()));
    ++p.sequence;
  }
}
BENCHMARK(BM_OscEncodeDecode);

void BM_OscLoopbackRoundTrip(benchmark::State& state) {
  PoseServer server(PoseServerOptions{});
  server.start();
  server.publish(PoseMessage{});
  OscEndpoint client;
  const OscPeer to = parse_osc_url("osc.udp://127.0.0.1:" + std::to_string(server.port()));
  const auto request = encode_get_pose();
  for (auto _ : state) {
    client.send_to(to, request);
    if (!client.receive(1000)) {
      state.SkipWithError("no reply within 1 s");
      break;
    }
  }
  server.stop();
}
BENCHMARK(BM_OscLoopbackRoundTrip)->UseRealTime();

}  // namespace
}  // namespace coloc::fusion
