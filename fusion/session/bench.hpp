#pragma once
// `coloc bench session`: throughput and input-to-output latency of one SessionNode on loopback.
// N simulated participants send a head pose and two controller poses each at `rate` Hz (tagged,
// to the shared port); a receiver takes every /coloc/users/... output. The input's time field
// carries its send time on the node's clock (session_clock), so each output's latency is its
// arrival time minus its time. Every input is accounted for: received, dropped and counted by the
// session (by reason), or lost unseen (which should be zero).

#include <cstddef>
#include <cstdint>
#include <vector>

#include "fusion/session/node.hpp"

namespace coloc::fusion::session {

struct LatencyBenchOptions {
  int participants = 8;
  double rate = 90.0;   // Hz per participant (head + controllers per tick)
  int controllers = 2;  // per participant
  double seconds = 10.0;
  void check() const;  // throws coloc::Error naming the field
};

struct LatencyBenchReport {
  std::uint64_t sent = 0;       // pose messages sent
  std::uint64_t published = 0;  // outputs the session produced
  std::uint64_t received = 0;   // outputs the receiver got
  std::uint64_t counted = 0;    // inputs the session dropped and counted (any reason)
  std::uint64_t lost = 0;       // sent - received - counted: lost without a count
  double median_ms = 0.0, p99_ms = 0.0, max_ms = 0.0;
  double messages_per_second = 0.0;  // inputs handled per second of wall time
  SessionNodeStats node;
};

LatencyBenchReport bench_session_latency(const LatencyBenchOptions& options);

}  // namespace coloc::fusion::session
