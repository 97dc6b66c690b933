// coloc fuse: the drift-filtered fusion as an OSC process (--listen) or on recorded TUM files
// (--xr/--global); coloc bench fusion: accuracy of the compared methods on a simulated session,
// the cost of one fused pose and the OSC loopback round trip, in one table.

#include <signal.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <exception>
#include <filesystem>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/stop_signals.hpp"
#include "Examples/coloc/verbs.hpp"
#include "fusion/benchmark.hpp"
#include "fusion/fuser.hpp"
#include "fusion/imu.hpp"
#include "fusion/osc_node.hpp"
#include "fusion/osc_player.hpp"
#include "fusion/replay.hpp"
#include "fusion/simulation.hpp"
#include "slam/core/atomic_file.hpp"
#include "slam/core/error.hpp"
#include "slam/core/trajectory.hpp"

namespace coloc::cli {
namespace {

struct FuseArgs {
  // OSC node
  int listen = -1;
  std::string bind = "127.0.0.1";
  std::vector<std::string> publish;
  bool broadcast = false;
  double duration = 0.0;
  // Recorded files
  std::string xr_file, imu_file, global_file, out_file;
  double latency = 0.0;
  // Filter
  double process_noise = 1e-3, measurement_noise = 0.9;
  double translation_sigma = 0.03, rotation_sigma = 0.01, gate_chi2 = 16.27;
  bool no_gating = false, no_time_alignment = false;
  double hold_after = 0.5, max_speed = 0.0, max_rate_deg = 0.0;
  bool json = false;
};

fusion::FuserOptions fuser_options(const FuseArgs& a) {
  fusion::FuserOptions o;
  o.filter.process_noise = a.process_noise;
  o.filter.measurement_noise = a.measurement_noise;
  o.filter.translation_sigma = a.translation_sigma;
  o.filter.rotation_sigma = a.rotation_sigma;
  o.filter.gate_chi2 = a.gate_chi2;
  o.filter.gating = !a.no_gating;
  o.time_alignment = !a.no_time_alignment;
  o.hold_after = a.hold_after;
  o.max_correction_speed = a.max_speed;
  o.max_correction_rate = a.max_rate_deg / kDegPerRad;
  o.check();
  // Effective values at start (OpenVINS habit), on stderr.
  spdlog::info(
      "fusion: Q {} R {} gating {} (chi2 {}, sigma {} m / {}) time alignment {} hold after {} s "
      "rate limit {} m/s {} deg/s",
      o.filter.process_noise, o.filter.measurement_noise, o.filter.gating, o.filter.gate_chi2,
      o.filter.translation_sigma, o.filter.rotation_sigma, o.time_alignment, o.hold_after,
      o.max_correction_speed, a.max_rate_deg);
  return o;
}

Json stats_json(const fusion::FuserStats& s, const fusion::FusionNodeStats* node) {
  Json j = {{"xr_poses", s.xr_poses},   {"global_poses", s.global_poses},
            {"accepted", s.accepted},   {"initialized", s.initialized},
            {"rejected", s.rejected},   {"lost", s.lost},
            {"unaligned", s.unaligned}, {"out_of_order", s.out_of_order}};
  if (node != nullptr) {
    const fusion::OscStats* osc = &node->osc;
    j["osc"] = {{"packets", osc->packets},
                {"messages", osc->messages},
                {"malformed", osc->malformed},
                {"oversized", osc->oversized},
                {"wrong_types", osc->wrong_types},
                {"unknown_address", osc->unknown_address},
                {"invalid_values", osc->invalid_values},
                {"out_of_order", node->out_of_order},
                {"implausible", node->implausible},
                {"resyncs", node->resyncs},
                {"published", node->published}};
  }
  return j;
}

void print_stats(const fusion::FuserStats& s, const fusion::FusionNodeStats* node, bool json) {
  if (json) {
    print_json(stats_json(s, node));
    return;
  }
  std::printf(
      "headset poses %llu, global poses %llu: accepted %llu, initialized %llu, rejected "
      "(gate) %llu, lost %llu, unaligned %llu, out of order %llu\n",
      static_cast<unsigned long long>(s.xr_poses), static_cast<unsigned long long>(s.global_poses),
      static_cast<unsigned long long>(s.accepted), static_cast<unsigned long long>(s.initialized),
      static_cast<unsigned long long>(s.rejected), static_cast<unsigned long long>(s.lost),
      static_cast<unsigned long long>(s.unaligned),
      static_cast<unsigned long long>(s.out_of_order));
  if (node != nullptr) {
    const fusion::OscStats* osc = &node->osc;
    std::printf(
        "osc: packets %llu, messages %llu, dropped: malformed %llu, oversized %llu, wrong types "
        "%llu, unknown address %llu, invalid values %llu, stale %llu, implausible %llu; "
        "streams re-anchored %llu; published %llu\n",
        static_cast<unsigned long long>(osc->packets),
        static_cast<unsigned long long>(osc->messages),
        static_cast<unsigned long long>(osc->malformed),
        static_cast<unsigned long long>(osc->oversized),
        static_cast<unsigned long long>(osc->wrong_types),
        static_cast<unsigned long long>(osc->unknown_address),
        static_cast<unsigned long long>(osc->invalid_values),
        static_cast<unsigned long long>(node->out_of_order),
        static_cast<unsigned long long>(node->implausible),
        static_cast<unsigned long long>(node->resyncs),
        static_cast<unsigned long long>(node->published));
    if (!osc->last_error.empty()) std::printf("last dropped packet: %s\n", osc->last_error.c_str());
  }
}

// Runs the OSC node until SIGINT/SIGTERM (or `duration` seconds). The signals are blocked
// before the receiver thread starts and taken synchronously with sigtimedwait: no handler, no
// polling.
// With --out, the fused poses (once a global pose anchored them) are kept and written when the
// node stops: 64 bytes a pose, about 21 MB an hour at 90 Hz.
void run_node(const FuseArgs& a) {
  if (!a.out_file.empty()) const AtomicFile probe(a.out_file);
  Trajectory fused;
  fusion::FusionNodeOptions options;
  options.fuser = fuser_options(a);
  options.endpoint.bind_address = a.bind;
  options.endpoint.port = a.listen;
  options.endpoint.broadcast = a.broadcast;
  options.publish = a.publish;
  if (!a.out_file.empty()) {
    options.on_fused = [&fused](const fusion::FusedPose& pose) {
      if (pose.state != fusion::FusionState::kWaiting)
        fused.push_back({pose.time, pose.world_from_head});
    };
  }
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  sigset_t previous;
  pthread_sigmask(SIG_BLOCK, &signals, &previous);
  // A shell starts background jobs with SIGINT ignored, and an ignored signal is discarded even
  // while blocked; with the default disposition it stays pending for sigwait.
  struct sigaction default_action {};
  default_action.sa_handler = SIG_DFL;
  struct sigaction previous_int {
  }, previous_term{};
  sigaction(SIGINT, &default_action, &previous_int);
  sigaction(SIGTERM, &default_action, &previous_term);
  {
    fusion::FusionNode node(options);
    node.start();
    spdlog::info(
        "fusion node: OSC in on udp {}:{} (/coloc/pose, /coloc/xr_pose, "
        "/coloc/get_pose), /coloc/fused_pose out to {} target(s); Ctrl-C to stop",
        a.bind, node.port(), a.publish.size());
    if (a.duration > 0.0) {
      timespec timeout{};
      timeout.tv_sec = static_cast<time_t>(a.duration);
      timeout.tv_nsec = static_cast<long>((a.duration - static_cast<double>(timeout.tv_sec)) * 1e9);
      sigtimedwait(&signals, nullptr, &timeout);
    } else {
      int received = 0;
      sigwait(&signals, &received);
    }
    node.stop();
    const fusion::FusionNodeStats s = node.stats();
    print_stats(s.fuser, &s, a.json);
    if (!a.out_file.empty()) write_tum_trajectory(a.out_file, fused);
  }
  sigaction(SIGINT, &previous_int, nullptr);
  sigaction(SIGTERM, &previous_term, nullptr);
  pthread_sigmask(SIG_SETMASK, &previous, nullptr);
}

// A recorded input without a single pose is an error naming the file (fusing nothing would
// "succeed" with an empty output).
Trajectory read_poses(const std::string& path) {
  Trajectory t = read_tum_trajectory(path);
  if (t.empty()) throw Error("no poses in the file (an empty trajectory)", {.file = path});
  return t;
}

// Prints the statistics, then fails when nothing useful came out: no output at all, or no
// global pose ever used (every output would be the raw, drifting input).
void finish_replay(const Trajectory& fused, const fusion::FuserStats& stats, bool json) {
  print_stats(stats, nullptr, json);
  if (fused.empty()) throw CliFailure("no fused pose came out; nothing written");
  if (stats.initialized == 0) {
    throw CliFailure(
        "no global pose could be used (none aligned in time with the input: check "
        "both files are on one clock); the output would be the raw input");
  }
}

// IMU mode on recorded files: an IMU log (EuRoC CSV) instead of headset poses; global poses
// must be world_from_body (the IMU's frame). One fused pose per IMU sample once anchored.
void run_imu_files(const FuseArgs& a) {
  fusion::ImuFuserOptions options;
  options.fuser = fuser_options(a);
  const std::vector<fusion::ImuSample> imu = fusion::read_imu_csv(a.imu_file);
  if (imu.empty()) throw Error("no IMU samples in the file", {.file = a.imu_file});
  const fusion::ImuReplay r =
      fusion::replay_imu(imu, fusion::delayed(read_poses(a.global_file), a.latency), options);
  if (!a.out_file.empty() && !r.fused.empty()) write_tum_trajectory(a.out_file, r.fused);
  if (!a.json) {
    std::printf("imu samples %llu (gaps %llu), integrator corrections %llu\n",
                static_cast<unsigned long long>(r.imu.imu_samples),
                static_cast<unsigned long long>(r.imu.gaps),
                static_cast<unsigned long long>(r.imu.corrections));
  }
  finish_replay(r.fused, r.fuser, a.json);
}

// Replays recorded headset and global trajectories (TUM files, same clock) through the fuser;
// global poses are delivered `latency` seconds after their stamp.
void run_files(const FuseArgs& a) {
  if (!a.out_file.empty()) const AtomicFile probe(a.out_file);
  const fusion::HeadsetReplay r = fusion::replay_headset(
      read_poses(a.xr_file), fusion::delayed(read_poses(a.global_file), a.latency),
      fuser_options(a));
  if (!a.out_file.empty() && !r.fused.empty()) write_tum_trajectory(a.out_file, r.fused);
  finish_replay(r.fused, r.stats, a.json);
}

void add_filter_options(CLI::App& cmd, FuseArgs& a) {
  cmd.add_option("--process-noise", a.process_noise, "Kalman Q per global pose (paper: 0.001)")
      ->capture_default_str();
  cmd.add_option("--measurement-noise", a.measurement_noise, "Kalman R (paper: 0.9)")
      ->capture_default_str();
  cmd.add_option("--translation-sigma", a.translation_sigma,
                 "Noise of one global pose in metres (scales the gate)")
      ->capture_default_str();
  cmd.add_option("--rotation-sigma", a.rotation_sigma,
                 "Noise of one global pose in quaternion units (~half angle, rad)")
      ->capture_default_str();
  cmd.add_option("--gate-chi2", a.gate_chi2, "Mahalanobis gate (squared, 3 dof)")
      ->capture_default_str();
  cmd.add_flag("--no-gating", a.no_gating, "Accept every global pose (the paper's filter)");
  cmd.add_flag("--no-time-alignment", a.no_time_alignment,
               "Compare global poses with the newest headset pose (the paper's filter)");
  cmd.add_option("--hold-after", a.hold_after, "Seconds without global poses before HOLDING")
      ->capture_default_str();
  cmd.add_option("--max-speed", a.max_speed, "Correction rate limit at the head, m/s (0 = off)")
      ->capture_default_str();
  cmd.add_option("--max-rate", a.max_rate_deg, "Correction rate limit, deg/s (0 = off)")
      ->capture_default_str();
}

// ---- coloc bench fusion -----------------------------------------------------------------------

struct FuseBenchArgs {
  fusion::SessionOptions session;
  std::string vive_log;
  int round_trips = 2000;
  bool json = false;
};

std::filesystem::path default_vive_log() {
  return recordings_dir() /
         "vive_tracker_vs_lasertracker/20201002_Exp1_Drift/drift20minExperiment.txt";
}

void run_bench(FuseBenchArgs a) {
  std::string noise_source = "default";
  const std::filesystem::path log =
      a.vive_log.empty() ? default_vive_log() : std::filesystem::path(a.vive_log);
  if (std::filesystem::exists(log)) {
    const fusion::StaticLogStats v = fusion::analyze_static_drift_log(log);
    a.session.drift.position_noise = v.position_noise;
    std::ostringstream s;
    s << "Vive log: " << v.samples << " poses, noise " << 1e3 * v.position_noise
      << " mm, 20-min wander " << 1e3 * v.wander << " mm";
    noise_source = s.str();
  }
  const fusion::SimulatedSession session = fusion::simulate_session(a.session);
  const std::vector<fusion::MethodResult> methods = fusion::compare_methods(session);
  const SampleStats pose_cost = fusion::time_fused_pose();
  const SampleStats round_trip = fusion::time_osc_round_trip(a.round_trips);

  if (a.json) {
    Json rows = Json::array();
    for (const fusion::MethodResult& method : methods) {
      const fusion::ErrorMetrics& m = method.metrics;
      rows.push_back({{"name", method.name},
                      {"position_rmse_m", m.position_rmse},
                      {"position_p95_m", m.position_p95},
                      {"rotation_rmse_deg", m.rotation_rmse * kDegPerRad},
                      {"rotation_p95_deg", m.rotation_p95 * kDegPerRad},
                      {"jitter_position_p99_m", m.jitter_position_p99},
                      {"jitter_rotation_p99_deg", m.jitter_rotation_p99 * kDegPerRad}});
    }
    print_json({{"methods", rows},
                {"fused_pose_us", {{"median", pose_cost.median}, {"p99", pose_cost.p99}}},
                {"osc_round_trip_us", {{"median", round_trip.median}, {"p99", round_trip.p99}}}});
    return;
  }
  const fusion::SessionOptions& s = a.session;
  std::printf(
      "fusion: simulated %.0f s walk (seed %u), headset %.0f Hz drifting (%.1f mm/s bias, %s), "
      "global poses %.0f Hz, %.1f cm / %.2f deg noise, %.0f ms latency, %.0f %% outliers\n",
      s.duration, s.seed, s.headset_rate, 1e3 * s.drift.position_bias, noise_source.c_str(),
      s.global_rate, 100.0 * s.global_position_sigma, s.global_rotation_sigma * kDegPerRad,
      1e3 * s.global_latency, 100.0 * s.outlier_fraction);
  std::printf("%-20s %9s %9s %9s %9s %11s %11s\n", "method", "pos RMSE", "pos p95", "rot RMSE",
              "rot p95", "jitter p99", "jitter p99");
  std::printf("%-20s %9s %9s %9s %9s %11s %11s\n", "", "cm", "cm", "deg", "deg", "mm", "deg");
  for (const fusion::MethodResult& r : methods) {
    const fusion::ErrorMetrics& m = r.metrics;
    std::printf("%-20s %9.2f %9.2f %9.3f %9.3f %11.2f %11.3f\n", r.name.c_str(),
                100.0 * m.position_rmse, 100.0 * m.position_p95, m.rotation_rmse * kDegPerRad,
                m.rotation_p95 * kDegPerRad, 1e3 * m.jitter_position_p99,
                m.jitter_rotation_p99 * kDegPerRad);
  }
  std::printf("%-20s median %8.3f us   p99 %8.3f us   (target < 2 us)\n", "one fused pose",
              pose_cost.median, pose_cost.p99);
  std::printf("%-20s median %8.1f us   p99 %8.1f us   (target < 200 us median, %zu trips)\n",
              "OSC round trip", round_trip.median, round_trip.p99, round_trip.count);
}

// ---- coloc fuse play ---------------------------------------------------------------------------

struct PlayArgs {
  std::string poses_file, address = std::string(fusion::kXrPoseAddress);
  std::string global_file;  // played as /coloc/pose, `latency` after its stamps
  double latency = 0.05;
  fusion::OscPlayOptions options;
};

// Plays the file in a thread of its own while this one waits for SIGINT/SIGTERM, which stop
// the play after the pose in flight.
void run_play(const PlayArgs& a) {
  a.options.check();
  std::vector<fusion::OscPlayStream> streams{{read_poses(a.poses_file), a.address, 0.0}};
  if (!a.global_file.empty())
    streams.push_back({read_poses(a.global_file), std::string(fusion::kPoseAddress), a.latency});
  std::size_t total = 0;
  for (const auto& stream : streams)
    total += stream.poses.size();
  block_stop_signals();
  const sigset_t signals = stop_signals();
  std::atomic<bool> stop{false}, done{false};
  fusion::OscPlayStats stats;
  std::exception_ptr failure;
  std::thread player([&] {
    try {
      stats = fusion::play_poses(streams, a.options, stop);
    } catch (...) {
      failure = std::current_exception();
    }
    done = true;
  });
  while (!done) {
    timespec wait{.tv_sec = 0, .tv_nsec = 100'000'000};
    if (sigtimedwait(&signals, nullptr, &wait) > 0) stop = true;
  }
  player.join();
  if (failure) std::rethrow_exception(failure);
  std::printf("played %zu of %zu poses (%zu send errors)%s\n", stats.sent, total, stats.send_errors,
              stats.stopped ? ", stopped" : "");
  if (stats.sent == 0) throw CliFailure("no pose could be sent");
}

void add_play_subcommand(CLI::App& cmd) {
  auto play_args = std::make_shared<PlayArgs>();
  CLI::App& play = *cmd.add_subcommand(
      "play", "Send recorded poses (TUM) over OSC at their recorded pace, as the device would");
  play.add_option("poses", play_args->poses_file, "Poses (TUM): a headset's xr_from_head")
      ->required()
      ->check(CLI::ExistingFile);
  play.add_option("--to", play_args->options.targets, "osc.udp://HOST:PORT (repeatable)")
      ->required();
  play.add_option("--address", play_args->address, "/coloc/xr_pose or /coloc/pose")
      ->capture_default_str();
  auto* play_global =
      play.add_option("--global", play_args->global_file,
                      "Also play these poses (TUM, world_from_head) as /coloc/pose, "
                      "as a localizer sends them")
          ->check(CLI::ExistingFile);
  play.add_option("--latency", play_args->latency,
                  "Seconds after its stamp each --global pose is sent")
      ->capture_default_str()
      ->needs(play_global);
  play.add_option("--speed", play_args->options.speed, "Faster (> 1) or slower than recorded")
      ->capture_default_str();
  play.callback([play_args] { run_play(*play_args); });
}

void add_fuse_bench(CLI::App& bench) {
  auto bargs = std::make_shared<FuseBenchArgs>();
  CLI::App& b = *bench.add_subcommand(
      "fusion", "Fusion accuracy on a simulated session, cost of one fused pose, OSC round trip");
  b.add_option("--duration", bargs->session.duration, "Simulated seconds")->capture_default_str();
  b.add_option("--rate", bargs->session.global_rate, "Global pose rate, Hz")->capture_default_str();
  b.add_option("--latency", bargs->session.global_latency, "Global pose latency, s")
      ->capture_default_str();
  b.add_option("--outliers", bargs->session.outlier_fraction, "Fraction of gross outliers")
      ->capture_default_str();
  b.add_option("--seed", bargs->session.seed, "Random seed")->capture_default_str();
  b.add_option("--vive-log", bargs->vive_log,
               "Static Vive drift log for the headset noise (default: the shared data's)");
  b.add_option("--round-trips", bargs->round_trips, "OSC round trips to time")
      ->capture_default_str();
  b.add_flag("--json", bargs->json, "Machine-readable output on stdout");
  b.callback([bargs] { run_bench(*bargs); });
}

}  // namespace

void add_fuse_verb(CLI::App& app, CLI::App& bench) {
  auto args = std::make_shared<FuseArgs>();
  CLI::App& cmd = *app.add_subcommand(
      "fuse",
      "Fuse drifting headset poses with global poses: as an OSC node (--listen) or on recorded "
      "files (--xr/--global TUM, or IMU mode --imu/--global)");
  auto* listen = cmd.add_option("--listen", args->listen,
                                "UDP port for OSC input (/coloc/pose, /coloc/xr_pose, "
                                "/coloc/get_pose); 0 = any free port")
                     ->check(CLI::Range(0, 65535));
  cmd.add_option("--bind", args->bind, "Address to bind (loopback unless told otherwise)")
      ->capture_default_str();
  cmd.add_option("--publish", args->publish,
                 "Send /coloc/fused_pose to osc.udp://HOST:PORT (repeatable)");
  cmd.add_flag("--broadcast", args->broadcast,
               "Allow --publish to a subnet broadcast address (SO_BROADCAST)");
  cmd.add_option("--duration", args->duration, "Stop after this many seconds (0: at SIGINT)")
      ->capture_default_str();
  auto* xr = cmd.add_option("--xr", args->xr_file, "Recorded headset poses xr_from_head (TUM)")
                 ->check(CLI::ExistingFile);
  auto* imu = cmd.add_option("--imu", args->imu_file,
                             "IMU mode: recorded IMU log, EuRoC CSV (t[ns],w xyz,a xyz)")
                  ->check(CLI::ExistingFile);
  auto* global = cmd.add_option("--global", args->global_file,
                                "Recorded global poses world_from_head, stamped at exposure (TUM)")
                     ->check(CLI::ExistingFile);
  cmd.add_option("--out", args->out_file,
                 "Write the fused poses world_from_head (TUM); with --listen, those anchored "
                 "by a global pose, when the node stops");
  cmd.add_option("--latency", args->latency,
                 "Replay: deliver global poses this many seconds after their stamp")
      ->capture_default_str();
  xr->needs(global);
  imu->needs(global);
  xr->excludes(imu);
  listen->excludes(xr);
  listen->excludes(imu);
  add_filter_options(cmd, *args);
  cmd.add_flag("--json", args->json, "Statistics as JSON on stdout");
  add_play_subcommand(cmd);

  cmd.callback([args, &cmd] {
    if (cmd.got_subcommand("play")) return;
    if (!args->xr_file.empty()) {
      run_files(*args);
    } else if (!args->imu_file.empty()) {
      run_imu_files(*args);
    } else if (args->listen >= 0) {
      run_node(*args);
    } else {
      throw CLI::RequiredError("--listen PORT, --xr/--global or --imu/--global");
    }
  });

  add_fuse_bench(bench);
}

}  // namespace coloc::cli
