#include "fusion/benchmark.hpp"

#include <numbers>

#include "fusion/osc_node.hpp"
#include "slam/core/error.hpp"

namespace coloc::fusion {

std::vector<MethodResult> compare_methods(const SimulatedSession& session) {
  FuserOptions limited = ours_options();
  limited.max_correction_speed = 0.05;
  limited.max_correction_rate = 3.0 * std::numbers::pi / 180.0;
  return {
      {"raw headset", evaluate_trajectory(raw_headset(session), session.truth)},
      {"snap to global",
       evaluate_trajectory(replay_session(session, snap_options()), session.truth)},
      {"paper filter",
       evaluate_trajectory(replay_session(session, paper_options()), session.truth)},
      {"ours (align+gate)",
       evaluate_trajectory(replay_session(session, ours_options()), session.truth)},
      {"ours + rate limit", evaluate_trajectory(replay_session(session, limited), session.truth)},
  };
}

SampleStats time_fused_pose(int batches, int batch) {
  SessionOptions options;
  options.duration = 20.0;
  const SimulatedSession s = simulate_session(options);
  DriftFuser fuser(ours_options());
  replay_session(s, fuser);  // warm up: a full headset buffer and an initialized filter
  double t = s.headset.back().timestamp;
  const SE3 pose = s.headset.back().world_from_cam;
  std::vector<double> per_call;
  double sink = 0.0;
  for (int b = 0; b < batches; ++b) {
    Stopwatch watch;
    for (int i = 0; i < batch; ++i) {
      t += 1.0 / 90.0;
      sink += fuser.push_xr_pose(t, pose).world_from_head.translation().x();
    }
    per_call.push_back(1e6 * watch.elapsed_seconds() / batch);
  }
  if (sink == 12345.678) per_call.push_back(0.0);  // keeps the loop from being optimized away
  return summarize(per_call);
}

SampleStats time_osc_round_trip(int round_trips) {
  PoseServer server(PoseServerOptions{});
  server.start();
  server.publish(PoseMessage{});
  OscEndpoint client;
  const OscPeer to = parse_osc_url("osc.udp://127.0.0.1:" + std::to_string(server.port()));
  const std::vector<std::uint8_t> request = encode_get_pose();
  std::vector<double> micros;
  micros.reserve(static_cast<std::size_t>(round_trips));
  for (int i = 0; i < round_trips + 50; ++i) {
    Stopwatch watch;
    client.send_to(to, request);
    // Only a lost reply ends the run: a busy machine may hold a loopback reply for seconds,
    // which the timings show.
    if (!client.receive(30000)) {
      throw Error("no /coloc/pose reply within 30 s on loopback port " +
                  std::to_string(server.port()));
    }
    if (i >= 50) micros.push_back(1e6 * watch.elapsed_seconds());  // after 50 warm-up trips
  }
  server.stop();
  return summarize(micros);
}

}  // namespace coloc::fusion
