// coloc bench session: one session process on loopback (throughput, input-to-output latency,
// every message accounted for) and, with --accuracy, the seeded multi-user simulation (every
// published pose against the truth, pairwise error against the calibrations' prediction, the
// locked-controller stability table).

#include <cstdio>
#include <memory>
#include <string>

#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/verbs.hpp"
#include "fusion/session/bench.hpp"
#include "fusion/session/simulate.hpp"
#include "slam/core/trajectory.hpp"

namespace coloc::cli {
namespace {

namespace ses = fusion::session;

struct SessionBenchArgs {
  ses::LatencyBenchOptions latency;
  bool accuracy = false;
  ses::MultiUserOptions sim;
  std::string walk;
  bool no_drift = false;
  bool no_gating = false;
  bool json = false;
};

Json latency_json(const ses::LatencyBenchReport& r) {
  return {{"sent", r.sent},
          {"published", r.published},
          {"received", r.received},
          {"counted", r.counted},
          {"lost", r.lost},
          {"median_ms", r.median_ms},
          {"p99_ms", r.p99_ms},
          {"max_ms", r.max_ms},
          {"messages_per_second", r.messages_per_second}};
}

void print_latency(const ses::LatencyBenchOptions& o, const ses::LatencyBenchReport& r) {
  std::printf("session on loopback: %d participants x %.0f Hz x (head + %d controllers), %.0f s\n",
              o.participants, o.rate, o.controllers, o.seconds);
  std::printf(
      "| inputs sent | published | received | dropped, counted | lost, uncounted | "
      "latency median | p99 | max | inputs/s |\n|---|---|---|---|---|---|---|---|---|\n");
  std::printf("| %llu | %llu | %llu | %llu | %llu | %.3f ms | %.3f ms | %.3f ms | %.0f |\n",
              static_cast<unsigned long long>(r.sent), static_cast<unsigned long long>(r.published),
              static_cast<unsigned long long>(r.received),
              static_cast<unsigned long long>(r.counted), static_cast<unsigned long long>(r.lost),
              r.median_ms, r.p99_ms, r.max_ms, r.messages_per_second);
}

Json accuracy_json(const ses::MultiUserReport& r) {
  Json users = Json::array(), pairs = Json::array();
  for (const ses::UserError& u : r.users) {
    users.push_back({{"id", u.id},
                     {"system", u.system},
                     {"head_position_rms_m", u.head_position_rms},
                     {"head_position_p95_m", u.head_position_p95},
                     {"head_rotation_rms_deg", u.head_rotation_rms * kDegPerRad},
                     {"controller_position_rms_m", u.controller_position_rms},
                     {"controller_position_p95_m", u.controller_position_p95},
                     {"calibration_error_m", u.calibration_error}});
  }
  for (const ses::PairError& p : r.pairs) {
    pairs.push_back({{"a", p.a},
                     {"b", p.b},
                     {"measured_position_rms_m", p.measured_position_rms},
                     {"predicted_position_rms_m", p.predicted_position_rms},
                     {"measured_rotation_rms_deg", p.measured_rotation_rms * kDegPerRad},
                     {"predicted_rotation_rms_deg", p.predicted_rotation_rms * kDegPerRad},
                     {"calibration_limited", p.calibration_limited}});
  }
  const ses::StabilityRow& s = r.stability;
  return {{"users", users},
          {"pairs", pairs},
          {"stability",
           {{"poses", s.poses},
            {"rotation_mean_deg", s.rotation_mean * kDegPerRad},
            {"rotation_rms_deg", s.rotation_rms * kDegPerRad},
            {"translation_mean_m", s.translation_mean},
            {"translation_rms_m", s.translation_rms}}}};
}

void print_accuracy(const ses::MultiUserOptions& o, const ses::MultiUserReport& r) {
  std::printf(
      "\nmulti-user simulation: %d participants, %d trial(s) x %.0f s, %s walk, drift %s, fuser "
      "gate %s\n",
      o.participants, o.trials, o.duration, o.walk.empty() ? "hall" : "given",
      o.drift ? "on" : "off", o.fuser_gating ? "on" : "off");
  std::printf(
      "| user | system | head rms | head p95 | head rot rms | controllers rms | controllers "
      "p95 | calibration error |\n|---|---|---|---|---|---|---|---|\n");
  for (const ses::UserError& u : r.users) {
    std::printf("| %s | %s | %.1f mm | %.1f mm | %.3f deg | %.1f mm | %.1f mm | %.1f mm |\n",
                u.id.c_str(), u.system.c_str(), u.head_position_rms * 1e3,
                u.head_position_p95 * 1e3, u.head_rotation_rms * kDegPerRad,
                u.controller_position_rms * 1e3, u.controller_position_p95 * 1e3,
                u.calibration_error * 1e3);
  }
  std::printf(
      "\n| pair | relative position rms: measured | predicted | ratio | rotation: measured | "
      "predicted | ratio | no drift |\n|---|---|---|---|---|---|---|---|\n");
  for (const ses::PairError& p : r.pairs) {
    std::printf("| %s-%s | %.1f mm | %.1f mm | %.2f | %.3f deg | %.3f deg | %.2f | %s |\n",
                p.a.c_str(), p.b.c_str(), p.measured_position_rms * 1e3,
                p.predicted_position_rms * 1e3, p.measured_position_rms / p.predicted_position_rms,
                p.measured_rotation_rms * kDegPerRad, p.predicted_rotation_rms * kDegPerRad,
                p.measured_rotation_rms / p.predicted_rotation_rms,
                p.calibration_limited ? "yes" : "");
  }
  const ses::StabilityRow& s = r.stability;
  std::printf("\nlocked controllers (%s controller 0 + %s controller 0), %zu poses, first trial\n",
              r.users[0].id.c_str(), r.users[1].id.c_str(), s.poses);
  std::printf("| | mean mu | delta_ave | delta_rms | delta_rms / mu |\n|---|---|---|---|---|\n");
  std::printf("| rotation | %.3f deg | %.3f deg | %.3f deg | %.2f %% |\n",
              s.rotation_mean * kDegPerRad, s.rotation_mean_abs * kDegPerRad,
              s.rotation_rms * kDegPerRad, 100.0 * s.rotation_rms / s.rotation_mean);
  std::printf("| translation | %.2f mm | %.2f mm | %.2f mm | %.2f %% |\n", s.translation_mean * 1e3,
              s.translation_mean_abs * 1e3, s.translation_rms * 1e3,
              100.0 * s.translation_rms / s.translation_mean);
}

void run_bench(SessionBenchArgs a) {
  Json out;
  if (a.accuracy) {
    if (!a.walk.empty()) a.sim.walk = read_tum_trajectory(a.walk);
    a.sim.drift = !a.no_drift;
    a.sim.fuser_gating = !a.no_gating;
    const ses::MultiUserReport r = ses::simulate_multi_user(a.sim);
    if (a.json)
      out["accuracy"] = accuracy_json(r);
    else
      print_accuracy(a.sim, r);
    if (a.json) print_json(out);
    return;
  }
  const ses::LatencyBenchReport r = ses::bench_session_latency(a.latency);
  if (a.json) {
    print_json({{"latency", latency_json(r)}});
  } else {
    print_latency(a.latency, r);
  }
}

}  // namespace

void add_session_bench(CLI::App& bench) {
  auto a = std::make_shared<SessionBenchArgs>();
  CLI::App& cmd = *bench.add_subcommand(
      "session", "Shared session: loopback latency, or --accuracy (multi-user simulation)");
  cmd.add_option("--participants", a->latency.participants, "Latency: participants")
      ->capture_default_str();
  cmd.add_option("--rate", a->latency.rate, "Latency: Hz per participant")->capture_default_str();
  cmd.add_option("--controllers", a->latency.controllers, "Latency: controllers per participant")
      ->capture_default_str();
  cmd.add_option("--seconds", a->latency.seconds, "Latency: seconds of traffic")
      ->capture_default_str();
  cmd.add_flag("--accuracy", a->accuracy, "Run the seeded multi-user simulation instead");
  cmd.add_option("--users", a->sim.participants, "Accuracy: participants (2-8)")
      ->capture_default_str();
  cmd.add_option("--duration", a->sim.duration, "Accuracy: seconds per trial")
      ->capture_default_str();
  cmd.add_option("--trials", a->sim.trials, "Accuracy: independent sessions")
      ->capture_default_str();
  cmd.add_option("--seed", a->sim.seed)->capture_default_str();
  cmd.add_option("--walk", a->walk,
                 "Accuracy: world_from_head TUM file (twin: headset/headset_groundtruth.txt)")
      ->check(CLI::ExistingFile);
  cmd.add_flag("--no-drift", a->no_drift, "Accuracy: no system drifts (calibration + noise)");
  cmd.add_flag("--no-gating", a->no_gating,
               "Accuracy: the fusers without their Mahalanobis gate (the prediction's model)");
  cmd.add_flag("--json", a->json);
  cmd.callback([a] { run_bench(*a); });
}

}  // namespace coloc::cli
