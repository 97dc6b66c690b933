// coloc session: several users of different XR systems in one scanned frame (fusion/session);
// coloc session check|stability; coloc bench session (loopback latency, multi-user accuracy).

#include <spdlog/spdlog.h>

#include <cstdio>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/stop_signals.hpp"
#include "Examples/coloc/verbs.hpp"
#include "fusion/session/bench.hpp"
#include "fusion/session/log.hpp"
#include "fusion/session/node.hpp"
#include "fusion/session/simulate.hpp"
#include "slam/core/atomic_file.hpp"
#include "slam/core/error.hpp"
#include "slam/core/trajectory.hpp"

namespace coloc::cli {
namespace {

namespace ses = fusion::session;

struct SessionArgs {
  std::string config;
  int listen = 0;
  std::string bind = "127.0.0.1";
  std::vector<std::string> publish;
  std::string log;
  double duration = 0.0;
  bool no_watch = false;
  bool json = false;
};

Json stats_json(const ses::SessionNodeStats& s) {
  const ses::SessionStats& c = s.session;
  return {{"head_poses", c.head_poses},
          {"controller_poses", c.controller_poses},
          {"global_poses", c.global_poses},
          {"anchor_poses", c.anchor_poses},
          {"published", c.published},
          {"sent", s.sent},
          {"replies", s.replies},
          {"non_finite", s.non_finite},
          {"stale_events", c.stale_events},
          {"reloads", c.reloads},
          {"reload_failures", c.reload_failures},
          {"dropped",
           {{"unknown_participant", c.unknown_participant},
            {"untagged", s.untagged},
            {"bad_controller", c.bad_controller},
            {"out_of_order", c.out_of_order},
            {"implausible", c.implausible},
            {"waiting_for_anchor", c.waiting_for_anchor},
            {"malformed", s.wire.malformed},
            {"oversized", s.wire.oversized},
            {"unknown_address", s.wire.unknown_address},
            {"wrong_types", s.wire.wrong_types},
            {"invalid_values", s.wire.invalid_values}}}};
}

void print_stats(const ses::SessionNodeStats& s, bool json) {
  if (json) {
    print_json(stats_json(s));
    return;
  }
  const ses::SessionStats& c = s.session;
  std::printf(
      "inputs: head %llu, controller %llu, global %llu, anchor %llu; published %llu (sent %llu), "
      "replies %llu, stale %llu, reloads %llu (failed %llu)\n",
      static_cast<unsigned long long>(c.head_poses),
      static_cast<unsigned long long>(c.controller_poses),
      static_cast<unsigned long long>(c.global_poses),
      static_cast<unsigned long long>(c.anchor_poses), static_cast<unsigned long long>(c.published),
      static_cast<unsigned long long>(s.sent), static_cast<unsigned long long>(s.replies),
      static_cast<unsigned long long>(c.stale_events), static_cast<unsigned long long>(c.reloads),
      static_cast<unsigned long long>(c.reload_failures));
  std::printf(
      "dropped: unknown participant %llu, untagged %llu, bad controller %llu, old sequence %llu, "
      "implausible %llu, before the anchor %llu, malformed %llu, oversized %llu, unknown address "
      "%llu, wrong types "
      "%llu, invalid values %llu\n",
      static_cast<unsigned long long>(c.unknown_participant),
      static_cast<unsigned long long>(s.untagged),
      static_cast<unsigned long long>(c.bad_controller),
      static_cast<unsigned long long>(c.out_of_order),
      static_cast<unsigned long long>(c.implausible),
      static_cast<unsigned long long>(c.waiting_for_anchor),
      static_cast<unsigned long long>(s.wire.malformed),
      static_cast<unsigned long long>(s.wire.oversized),
      static_cast<unsigned long long>(s.wire.unknown_address),
      static_cast<unsigned long long>(s.wire.wrong_types),
      static_cast<unsigned long long>(s.wire.invalid_values));
  if (!s.wire.last_error.empty())
    std::printf("last dropped packet: %s\n", s.wire.last_error.c_str());
}

void log_config(const ses::Session& session) {
  const ses::SessionConfig& c = session.config();
  spdlog::info("session: anchor camera '{}' ({}), stale after {} s, {} participant(s)",
               c.anchor.camera,
               c.anchor.mode == ses::AnchorMode::kFixed
                   ? "fixed"
                   : "localized on port " + std::to_string(c.anchor.localize_port),
               c.stale_after, c.participants.size());
  for (const ses::ParticipantConfig& p : c.participants) {
    const SE3 w = session.snapshot(p.id).world_from_vr;
    spdlog::info(
        "  {} ({}, {}): calibration {}, {} controller(s), port {}, drift correction {}; "
        "world_from_vr t = ({:.3f}, {:.3f}, {:.3f})",
        p.id, ses::to_string(p.kind), p.system.empty() ? "-" : p.system, p.calibration.string(),
        p.controllers, p.port > 0 ? std::to_string(p.port) : "shared", p.drift_correction,
        w.translation().x(), w.translation().y(), w.translation().z());
  }
}

void run_session(const SessionArgs& a) {
  ses::Session session(ses::read_session_config(a.config));
  log_config(session);
  ses::SessionNodeOptions options;
  options.bind_address = a.bind;
  options.port = a.listen;
  options.publish = a.publish;
  options.watch_calibrations = !a.no_watch;
  std::unique_ptr<AtomicFile> log_file;
  std::ofstream log;
  ses::LogSink sink;
  if (!a.log.empty()) {
    log_file = std::make_unique<AtomicFile>(a.log);
    log.open(log_file->temp_path());
    ses::write_log_header(log);
    sink = [&log](const ses::LogRecord& r) { ses::write_log_record(log, r); };
  }
  // Signals blocked before the node's thread starts, so only wait_for_stop_signal takes them.
  block_stop_signals();
  ses::SessionNodeStats stats;
  {
    ses::SessionNode node(std::move(session), options, sink);
    node.start();
    spdlog::info(
        "session: OSC in on udp {}:{}, /coloc/users/<id>/... out to {} target(s); Ctrl-C "
        "to stop",
        a.bind, node.port(), a.publish.size());
    wait_for_stop_signal(a.duration > 0.0 ? a.duration : -1.0);
    node.stop();
    stats = node.stats();
  }
  if (log_file) {
    log.close();
    if (!log) throw Error("cannot write the session log", ErrorContext{.file = a.log});
    log_file->commit();
  }
  print_stats(stats, a.json);
}

void run_check(const std::string& config, bool json) {
  ses::Session session(ses::read_session_config(config));
  if (!json) {
    log_config(session);
    std::printf("%s: %zu participant(s), calibrations readable\n", config.c_str(),
                session.config().participants.size());
    return;
  }
  Json users = Json::array();
  for (const ses::ParticipantConfig& p : session.config().participants) {
    users.push_back(
        {{"id", p.id},
         {"kind", ses::to_string(p.kind)},
         {"world_from_vr", json_row_major(session.snapshot(p.id).world_from_vr.matrix())}});
  }
  print_json({{"participants", users}});
}

struct StabilityArgs {
  std::string config, log, a, b;
  double max_dt = 0.01;
  bool json = false;
};

std::pair<std::string, int> device_of(const std::string& text) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos) return {text, 0};
  return {text.substr(0, colon), std::stoi(text.substr(colon + 1))};
}

// The paper's Table 2: mean, mean absolute and RMS deviation, and the RMS deviation relative to
// the mean.
void print_stability(const ses::StabilityRow& r, bool json) {
  if (json) {
    print_json({{"poses", r.poses},
                {"rotation_mean_deg", r.rotation_mean * kDegPerRad},
                {"rotation_mean_abs_deg", r.rotation_mean_abs * kDegPerRad},
                {"rotation_rms_deg", r.rotation_rms * kDegPerRad},
                {"translation_mean_m", r.translation_mean},
                {"translation_mean_abs_m", r.translation_mean_abs},
                {"translation_rms_m", r.translation_rms}});
    return;
  }
  std::printf("locked controllers, %zu paired poses (An et al. 2023, Table 2)\n", r.poses);
  std::printf("| | mean mu | delta_ave | delta_rms | delta_rms / mu |\n|---|---|---|---|---|\n");
  std::printf("| rotation | %.3f deg | %.3f deg | %.3f deg | %.2f %% |\n",
              r.rotation_mean * kDegPerRad, r.rotation_mean_abs * kDegPerRad,
              r.rotation_rms * kDegPerRad, 100.0 * r.rotation_rms / r.rotation_mean);
  std::printf("| translation | %.2f mm | %.2f mm | %.2f mm | %.2f %% |\n", r.translation_mean * 1e3,
              r.translation_mean_abs * 1e3, r.translation_rms * 1e3,
              100.0 * r.translation_rms / r.translation_mean);
}

void run_stability(const StabilityArgs& s) {
  const ses::SessionConfig config = ses::read_session_config(s.config);
  const auto [a, na] = device_of(s.a);
  const auto [b, nb] = device_of(s.b);
  print_stability(
      ses::locked_stability(ses::read_session_log(s.log), config, a, na, b, nb, s.max_dt), s.json);
}

}  // namespace

void add_session_verb(CLI::App& app, CLI::App& bench) {
  auto a = std::make_shared<SessionArgs>();
  CLI::App& cmd = *app.add_subcommand(
      "session", "Several users of different XR systems in one scanned frame (OSC node)");
  cmd.require_subcommand(0, 1);
  cmd.add_option("--config", a->config, "Session description (YAML, see README)");
  cmd.add_option("--listen", a->listen, "Shared UDP port (0: any free one)")->capture_default_str();
  cmd.add_option("--bind", a->bind, "Address to bind (0.0.0.0: every interface)")
      ->capture_default_str();
  cmd.add_option("--publish", a->publish, "osc.udp://HOST:PORT targets of /coloc/users/...");
  cmd.add_option("--log", a->log, "Session log (CSV of every input; for `session stability`)");
  cmd.add_option("--duration", a->duration, "Stop after S seconds (0: at Ctrl-C)");
  cmd.add_flag("--no-watch", a->no_watch, "Do not reload calibration files when they change");
  cmd.add_flag("--json", a->json, "Statistics at exit as JSON");
  cmd.callback([a, &cmd] {
    if (cmd.get_subcommands().empty()) {
      if (a->config.empty()) throw CLI::RequiredError("--config");
      run_session(*a);
    }
  });

  auto check = std::make_shared<std::pair<std::string, bool>>();
  CLI::App& c = *cmd.add_subcommand("check", "Validate a session description, show placements");
  // No CLI::ExistingFile: the readers check each path (a FIFO, a directory), exit 1 naming it.
  c.add_option("CONFIG", check->first)->required();
  c.add_flag("--json", check->second);
  c.callback([check] { run_check(check->first, check->second); });

  auto st = std::make_shared<StabilityArgs>();
  CLI::App& s = *cmd.add_subcommand("stability", "Two locked controllers from a session log");
  s.add_option("--config", st->config)->required();
  s.add_option("--log", st->log)->required();
  s.add_option("--a", st->a, "Participant and controller, e.g. vive:0")->required();
  s.add_option("--b", st->b, "Participant and controller, e.g. quest:0")->required();
  s.add_option("--max-dt", st->max_dt, "Pairing window on the session clock, s")
      ->capture_default_str();
  s.add_flag("--json", st->json);
  s.callback([st] { run_stability(*st); });

  add_session_bench(bench);
}

}  // namespace coloc::cli
