// coloc handeye solve|simulate|link|stability|next|franka, and coloc bench handeye: AX=XB
// registration of a VR system to the camera space (An et al. 2023; registration/handeye).
// Frames: vr_from_device (VR system), camera_from_marker (PnP), X = device_from_marker,
// M_c2v = vr_from_camera, T_A2B = vr_b_from_vr_a. File formats: registration/handeye/io.hpp.

#include <spdlog/spdlog.h>

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>

#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/verbs.hpp"
#include "registration/handeye/compose.hpp"
#include "registration/handeye/guidance.hpp"
#include "registration/handeye/handeye.hpp"
#include "registration/handeye/io.hpp"
#include "registration/handeye/opencv/compare.hpp"
#include "registration/handeye/opencv/visp_franka.hpp"
#include "registration/handeye/simulate.hpp"
#include "slam/core/error.hpp"
#include "slam/core/timing.hpp"

namespace coloc::cli {
namespace {

namespace he = coloc::registration::handeye;
namespace fs = std::filesystem;

struct SolveArgs {
  std::string pairs, device, marker, output;
  std::string target = "m2d", pair_mode = "all";
  double max_dt = 0.02;
  bool unknown_scale = false, robust = false, json = false;
};

Json matrix_json(const SE3& pose) {
  return json_rows(pose.matrix());
}

void print_pose(const char* name, const SE3& pose) {
  const Eigen::Vector3d& t = pose.translation();
  const Eigen::Vector3d w = pose.so3().log();
  std::printf("%s: t = [%.5f %.5f %.5f] m, rotation vector = [%.5f %.5f %.5f] rad (%.3f deg)\n",
              name, t.x(), t.y(), t.z(), w.x(), w.y(), w.z(), w.norm() * kDegPerRad);
}

std::vector<he::Registration> load_registrations(const SolveArgs& a) {
  std::vector<he::TimedRegistration> timed;
  if (!a.pairs.empty()) {
    timed = he::read_pairs_file(a.pairs);
  } else if (!a.device.empty() && !a.marker.empty()) {
    timed = he::match_by_time(he::read_pose_csv(a.device), he::read_pose_csv(a.marker), a.max_dt);
    spdlog::info("matched {} registrations by timestamp (max dt {} s)", timed.size(), a.max_dt);
  } else {
    throw Error("give --pairs FILE, or --device and --marker", {.field = "--pairs"});
  }
  std::vector<he::Registration> out;
  out.reserve(timed.size());
  for (const auto& t : timed)
    out.push_back(t.registration);
  return out;
}

void print_summary_json(const he::Summary& s) {
  const he::Conditioning& c = s.conditioning;
  Json j = {{"usable", s.is_solution_usable()},
            {"X", matrix_json(s.device_from_marker)},
            {"vr_from_camera", matrix_json(s.vr_from_camera)}};
  if (s.scale_estimated) {
    j["sigma"] = s.sigma;
    if (s.sigma_stddev) j["sigma_stddev"] = *s.sigma_stddev;
  }
  j["registrations"] = s.used.size();
  j["used"] = s.num_used;
  j["residual_rotation_rms_deg"] = s.residuals.rotation_rms * kDegPerRad;
  j["residual_translation_rms_m"] = s.residuals.translation_rms;
  j["conditioning"] = {{"axis_spread_deg", c.axis_spread * kDegPerRad},
                       {"translation_min_singular_value", c.translation_min_singular_value},
                       {"pairs_used", c.pairs_used},
                       {"pairs_rejected", c.pairs_rejected},
                       {"pairs_small", c.pairs_small}};
  j["X_rotation_stddev_deg"] = s.rotation_stddev * kDegPerRad;
  j["X_translation_stddev_m"] = s.translation_stddev;
  j["message"] = s.message;
  print_json(j);
}

void print_summary_text(const he::Summary& s) {
  std::printf("usable: %s%s%s\n", s.is_solution_usable() ? "yes" : "NO",
              s.message.empty() ? "" : " - ", s.message.c_str());
  print_pose("X = device_from_marker", s.device_from_marker);
  print_pose("M_c2v = vr_from_camera", s.vr_from_camera);
  if (s.scale_estimated) std::printf("sigma (marker scale): %.6f\n", s.sigma);
  std::printf("registrations used: %d of %zu\n", s.num_used, s.used.size());
  std::printf("residual rms: %.3f deg, %.2f mm\n", s.residuals.rotation_rms * kDegPerRad,
              s.residuals.translation_rms * 1e3);
  std::printf("X uncertainty (1 sigma): %.3f deg, %.2f mm\n", s.rotation_stddev * kDegPerRad,
              s.translation_stddev * 1e3);
  const he::Conditioning& c = s.conditioning;
  std::printf(
      "conditioning: axis spread %.1f deg, translation min singular value %.3f, pairs used %d, "
      "rejected %d, too small %d\n",
      c.axis_spread * kDegPerRad, c.translation_min_singular_value, c.pairs_used, c.pairs_rejected,
      c.pairs_small);
}

void run_solve(const SolveArgs& a) {
  he::Options options;
  options.target = a.target == "c2v" ? he::Target::kVrFromCamera : he::Target::kDeviceFromMarker;
  options.pairs = a.pair_mode == "consecutive" ? he::PairMode::kConsecutive : he::PairMode::kAll;
  options.estimate_scale = a.unknown_scale;
  options.robust = a.robust;
  const he::Summary s = he::solve(load_registrations(a), options);
  if (a.json) {
    print_summary_json(s);
  } else {
    print_summary_text(s);
  }
  if (!a.output.empty()) {
    he::write_calibration(a.output, {s.device_from_marker, s.vr_from_camera, s.sigma});
  }
  if (!s.is_solution_usable()) throw CliFailure("the solution is not usable: " + s.message);
}

struct SimulateArgs {
  std::string out;
  int registrations = 10;
  double noise_scale = 1.0, outliers = 0.0, scale = 1.0, depth_noise = 0.0;
  std::uint64_t seed = 1;
};

void run_simulate(const SimulateArgs& a) {
  he::SimulationOptions o;
  o.num_registrations = a.registrations;
  o.device_rotation_noise *= a.noise_scale;
  o.device_translation_noise *= a.noise_scale;
  o.marker_rotation_noise *= a.noise_scale;
  o.marker_translation_noise *= a.noise_scale;
  o.marker_depth_noise = a.depth_noise;
  o.outlier_fraction = a.outliers;
  o.scale = a.scale;
  o.seed = a.seed;
  const he::Simulation sim = he::simulate(o);
  fs::create_directories(a.out);
  std::vector<he::TimedRegistration> timed;
  std::vector<he::TimedPose> device, marker;
  for (std::size_t k = 0; k < sim.registrations.size(); ++k) {
    const double t = 2.0 * static_cast<double>(k);
    timed.push_back({t, sim.registrations[k]});
    device.push_back({t, sim.registrations[k].vr_from_device});
    marker.push_back({t + 0.004, sim.registrations[k].camera_from_marker});  // 4 ms camera lag
  }
  he::write_pairs_file(fs::path(a.out) / "pairs.csv", timed);
  he::write_pose_csv(fs::path(a.out) / "device.csv", device);
  he::write_pose_csv(fs::path(a.out) / "marker.csv", marker);
  he::write_calibration(fs::path(a.out) / "truth.yaml",
                        {sim.device_from_marker, sim.vr_from_camera, sim.scale});
  std::printf(
      "wrote %s/{pairs.csv, device.csv, marker.csv, truth.yaml}: %d registrations, %d "
      "outliers\n",
      a.out.c_str(), a.registrations,
      static_cast<int>(std::count(sim.is_outlier.begin(), sim.is_outlier.end(), true)));
}

void run_link(const std::string& a_path, const std::string& b_path, bool json) {
  const he::CalibrationFile a = he::read_calibration(a_path);
  const he::CalibrationFile b = he::read_calibration(b_path);
  const SE3 b_from_a = he::vr_b_from_vr_a(a.vr_from_camera, b.vr_from_camera);
  if (json) {
    print_json({{"vr_b_from_vr_a", matrix_json(b_from_a)},
                {"vr_a_from_vr_b", matrix_json(b_from_a.inverse())}});
  } else {
    print_pose("T_A2B = vr_b_from_vr_a", b_from_a);
    print_pose("T_B2A = vr_a_from_vr_b", b_from_a.inverse());
  }
}

struct StabilityArgs {
  std::string calib_a, calib_b, device_a, device_b;
  double max_dt = 0.02;
  bool json = false;
};

void run_stability(const StabilityArgs& a) {
  const he::CalibrationFile ca = he::read_calibration(a.calib_a);
  const he::CalibrationFile cb = he::read_calibration(a.calib_b);
  // Pair the two systems' controller poses by time (the pairs type carries both).
  const auto matched =
      he::match_by_time(he::read_pose_csv(a.device_a), he::read_pose_csv(a.device_b), a.max_dt);
  std::vector<SE3> pa, pb;
  for (const auto& m : matched) {
    pa.push_back(m.registration.vr_from_device);
    pb.push_back(m.registration.camera_from_marker);  // here: vr_b_from_device_b
  }
  const he::Dispersion d =
      he::locked_controller_stability(pa, pb, ca.vr_from_camera, cb.vr_from_camera);
  if (a.json) {
    print_json({{"poses", pa.size()},
                {"mean", matrix_json(d.mean)},
                {"rotation_mean_abs_deg", d.rotation_mean_abs * kDegPerRad},
                {"rotation_rms_deg", d.rotation_rms * kDegPerRad},
                {"translation_mean_abs_m", d.translation_mean_abs},
                {"translation_rms_m", d.translation_rms}});
    return;
  }
  std::printf("%zu matched poses\n", pa.size());
  print_pose("mean device_b_from_device_a (mu)", d.mean);
  std::printf("delta_ave: %.3f deg, %.2f mm; delta_rms: %.3f deg, %.2f mm\n",
              d.rotation_mean_abs * kDegPerRad, d.translation_mean_abs * 1e3,
              d.rotation_rms * kDegPerRad, d.translation_rms * 1e3);
}

void run_next(const SolveArgs& a) {
  const std::vector<he::Registration> regs = load_registrations(a);
  const he::SessionStatus status = he::session_status(regs);
  std::printf("%d registrations: %s\n", status.registrations, status.advice.c_str());
  if (regs.size() >= 2) {
    const he::NextRegistrationAdvice last =
        he::assess_next_registration(std::span(regs).first(regs.size() - 1), regs.back());
    std::printf("last registration: %s\n", last.advice.c_str());
  }
}

void run_franka(const std::string& dir, bool robust, bool json) {
  const he::FrankaSession session = he::load_visp_franka_eye_to_hand(dir);
  spdlog::info("tag found in {} of {} images", session.registrations.size(), session.num_images);
  he::Options options;
  options.robust = robust;
  const he::Summary s = he::solve(session.registrations, options);
  std::vector<he::Registration> used;
  for (std::size_t k = 0; k < s.used.size(); ++k) {
    if (s.used[k]) used.push_back(session.registrations[k]);
  }
  const he::Dispersion d =
      he::dispersion(he::vr_from_camera_per_registration(used, s.device_from_marker, s.sigma));
  if (json) {
    print_summary_json(s);
    return;
  }
  print_summary_text(s);
  std::printf(
      "consistency of base_from_camera over %zu registrations: rotation mean %.3f rms "
      "%.3f max %.3f deg, translation mean %.2f rms %.2f max %.2f mm\n",
      used.size(), d.rotation_mean_abs * kDegPerRad, d.rotation_rms * kDegPerRad,
      d.rotation_max * kDegPerRad, d.translation_mean_abs * 1e3, d.translation_rms * 1e3,
      d.translation_max * 1e3);
  for (const he::OpencvMethod& m : he::opencv_methods()) {
    const SE3 x = he::opencv_hand_eye(used, m.method);
    const he::Dispersion o = he::dispersion(he::vr_from_camera_per_registration(used, x));
    std::printf("  %-18s rotation rms %.3f deg, translation rms %.2f mm\n", m.name,
                o.rotation_rms * kDegPerRad, o.translation_rms * 1e3);
  }
}

struct Scenario {
  std::string name;
  he::SimulationOptions simulation;
  he::Options options;
  bool opencv = true;
};

std::vector<Scenario> bench_scenarios() {
  std::vector<Scenario> out;
  he::SimulationOptions protocol;  // OpenCV's protocol: 0.002 rad / 5 mm marker, 0.001 / 1 mm
  protocol.seed = 100000;
  out.push_back({"protocol (10 poses)", protocol, {}, true});
  for (double f : {0.25, 0.5, 2.0, 4.0}) {
    he::SimulationOptions s = protocol;
    s.device_rotation_noise *= f;
    s.device_translation_noise *= f;
    s.marker_rotation_noise *= f;
    s.marker_translation_noise *= f;
    std::ostringstream name;
    name << "noise x" << f;
    out.push_back({name.str(), s, {}, true});
  }
  he::SimulationOptions depth = protocol;
  depth.marker_depth_noise = 0.015;
  out.push_back({"protocol + 15 mm PnP depth noise", depth, {}, true});
  for (double outliers : {0.0, 0.1, 0.2}) {
    he::SimulationOptions s = protocol;
    s.outlier_fraction = outliers;
    he::Options robust;
    robust.robust = true;
    std::ostringstream name;
    name << "outliers " << outliers * 100 << " % (ours --robust)";
    out.push_back({name.str(), s, robust, true});
  }
  he::SimulationOptions scale = protocol;
  scale.scale = 0.8;
  he::Options unknown;
  unknown.estimate_scale = true;
  out.push_back({"unknown scale (sigma 0.8, ours --unknown-scale)", scale, unknown, false});
  return out;
}

void print_timing(const char* name, const std::vector<he::Registration>& regs,
                  const he::Options& options, int repeats) {
  std::vector<double> us;
  for (int k = 0; k < repeats; ++k) {
    Stopwatch watch;
    const he::Summary s = he::solve(regs, options);
    us.push_back(watch.elapsed_ms() * 1e3);
    if (!s.is_solution_usable()) throw CliFailure("benchmark solve not usable");
  }
  const SampleStats stats = summarize(us);
  std::printf("  %-44s median %8.1f us   p99 %8.1f us\n", name, stats.median, stats.p99);
}

void run_bench(int trials, int repeats) {
  std::printf("coloc bench handeye: %d trials per row, errors of X = device_from_marker\n", trials);
  std::printf("  %-20s %12s %12s %12s %12s %10s\n", "method", "rot med deg", "rot p90 deg",
              "trans med mm", "trans p90 mm", "sigma med");
  for (const Scenario& sc : bench_scenarios()) {
    std::printf("%s\n", sc.name.c_str());
    for (const he::MethodErrors& m :
         he::compare_methods(sc.simulation, trials, sc.options, "ours", sc.opencv)) {
      std::printf("  %-20s %12.4f %12.4f %12.3f %12.3f", m.name.c_str(),
                  quantile(m.rotation, 0.5) * kDegPerRad, quantile(m.rotation, 0.9) * kDegPerRad,
                  quantile(m.translation, 0.5) * 1e3, quantile(m.translation, 0.9) * 1e3);
      if (!m.sigma.empty()) std::printf(" %10.5f", quantile(m.sigma, 0.5));
      std::printf("\n");
    }
  }
  he::SimulationOptions o;
  o.seed = 7;
  const std::vector<he::Registration> regs = he::simulate(o).registrations;
  std::printf("solve time, 10 registrations (%d repeats, wall clock):\n", repeats);
  he::Options linear;
  linear.refine = false;
  linear.estimate_covariance = false;
  print_timing("linear (paper) only", regs, linear, repeats);
  print_timing("default (linear + Ceres + noise est. + cov.)", regs, {}, repeats);
  he::Options robust;
  robust.robust = true;
  print_timing("robust (RANSAC, 120 triples) + refinement", regs, robust, repeats);
}

void add_handeye_bench(CLI::App& bench) {
  auto args = std::make_shared<std::pair<int, int>>(100, 300);
  CLI::App& b = *bench.add_subcommand(
      "handeye", "Hand-eye accuracy vs cv::calibrateHandEye (all methods) and solve time");
  b.add_option("--trials", args->first, "Simulated sessions per row")->capture_default_str();
  b.add_option("--repeats", args->second, "Timed solves")->capture_default_str();
  b.callback([args] { run_bench(args->first, args->second); });
}

}  // namespace

void add_handeye_verb(CLI::App& app, CLI::App& bench) {
  CLI::App& cmd = *app.add_subcommand("handeye", "Hand-eye registration of VR systems (AX=XB)");
  cmd.require_subcommand(1);

  auto solve_args = std::make_shared<SolveArgs>();
  auto add_inputs = [](CLI::App& c, SolveArgs& a) {
    c.add_option("--pairs", a.pairs, "Pairs file: t, vr_from_device (7), camera_from_marker (7)")
        ->check(CLI::ExistingFile);
    c.add_option("--device", a.device, "Device CSV t,tx,ty,tz,qx,qy,qz,qw (vr_from_device)")
        ->check(CLI::ExistingFile);
    c.add_option("--marker", a.marker, "Marker CSV t,tx,ty,tz,qx,qy,qz,qw (camera_from_marker)")
        ->check(CLI::ExistingFile);
    c.add_option("--max-dt", a.max_dt, "Timestamp tolerance for --device/--marker (s)")
        ->check(non_negative_seconds())
        ->capture_default_str();
  };
  CLI::App& solve = *cmd.add_subcommand("solve", "Solve X = device_from_marker and M_c2v");
  add_inputs(solve, *solve_args);
  solve.add_option("--target", solve_args->target, "Unknown of the linear stage")
      ->check(CLI::IsMember({"m2d", "c2v"}))
      ->capture_default_str();
  solve.add_option("--pair-mode", solve_args->pair_mode, "Pairs (i, j): all i < j or consecutive")
      ->check(CLI::IsMember({"all", "consecutive"}))
      ->capture_default_str();
  solve.add_flag("--unknown-scale", solve_args->unknown_scale, "Estimate the marker scale sigma");
  solve.add_flag("--robust", solve_args->robust, "RANSAC over registrations");
  solve.add_flag("--json", solve_args->json, "Machine-readable output on stdout");
  solve.add_option("--output", solve_args->output, "Write the calibration YAML (for link)");
  solve.callback([solve_args] { run_solve(*solve_args); });

  auto sim = std::make_shared<SimulateArgs>();
  CLI::App& simulate = *cmd.add_subcommand("simulate", "Write a simulated session");
  simulate.add_option("--out", sim->out, "Output directory")->required();
  simulate.add_option("-n,--registrations", sim->registrations)->capture_default_str();
  simulate.add_option("--noise-scale", sim->noise_scale, "x OpenCV protocol noise")
      ->capture_default_str();
  simulate.add_option("--depth-noise", sim->depth_noise, "Extra PnP depth noise (m)");
  simulate.add_option("--outliers", sim->outliers, "Outlier fraction")->capture_default_str();
  simulate.add_option("--scale", sim->scale, "True sigma (wrong marker size)");
  simulate.add_option("--seed", sim->seed)->capture_default_str();
  simulate.callback([sim] { run_simulate(*sim); });

  auto link = std::make_shared<std::pair<std::vector<std::string>, bool>>();
  CLI::App& l = *cmd.add_subcommand("link", "T_A2B between two VR systems: link A.yaml B.yaml");
  l.add_option("CALIBRATIONS", link->first, "A.yaml B.yaml from solve --output")
      ->required()
      ->expected(2)
      ->check(CLI::ExistingFile);
  l.add_flag("--json", link->second);
  l.callback([link] { run_link(link->first[0], link->first[1], link->second); });

  auto st = std::make_shared<StabilityArgs>();
  CLI::App& stab = *cmd.add_subcommand("stability", "Two controllers locked together");
  stab.add_option("A_YAML", st->calib_a)->required()->check(CLI::ExistingFile);
  stab.add_option("B_YAML", st->calib_b)->required()->check(CLI::ExistingFile);
  stab.add_option("--device-a", st->device_a, "vr_a_from_device_a CSV")->required();
  stab.add_option("--device-b", st->device_b, "vr_b_from_device_b CSV")->required();
  stab.add_option("--max-dt", st->max_dt)->check(non_negative_seconds())->capture_default_str();
  stab.add_flag("--json", st->json);
  stab.callback([st] { run_stability(*st); });

  auto next_args = std::make_shared<SolveArgs>();
  CLI::App& next = *cmd.add_subcommand("next", "Guidance: what to do next in a session");
  add_inputs(next, *next_args);
  next.callback([next_args] { run_next(*next_args); });

  auto franka = std::make_shared<std::tuple<std::string, bool, bool>>();
  CLI::App& f = *cmd.add_subcommand("franka", "Real data: ViSP Franka eye-to-hand folder");
  f.add_option("DIR", std::get<0>(*franka))->required()->check(CLI::ExistingDirectory);
  f.add_flag("--robust", std::get<1>(*franka));
  f.add_flag("--json", std::get<2>(*franka));
  f.callback(
      [franka] { run_franka(std::get<0>(*franka), std::get<1>(*franka), std::get<2>(*franka)); });

  add_handeye_bench(bench);
}

}  // namespace coloc::cli
