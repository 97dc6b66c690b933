// coloc eval ate|rpe GT EST: trajectory accuracy as the TUM tools and evo compute it.

#include <cstdio>

#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/plot.hpp"
#include "Examples/coloc/verbs.hpp"
#include "slam/core/error.hpp"
#include "slam/core/trajectory.hpp"
#include "slam/eval/trajectory_error.hpp"

namespace coloc::cli {
namespace {

struct EvalArgs {
  std::string ground_truth;
  std::string estimate;
  std::string align = "se3";
  double max_dt = 0.02;
  std::size_t delta = 1;
  bool json = false;
  std::string plot;
};

void add_common(CLI::App& cmd, EvalArgs& a, const std::string& default_align) {
  a.align = default_align;
  // No CLI::ExistingFile: the trajectory reader checks each path (a FIFO, a directory) and
  // fails with exit 1 naming it.
  cmd.add_option("GT", a.ground_truth, "Ground-truth trajectory (TUM format)")->required();
  cmd.add_option("EST", a.estimate, "Estimated trajectory (TUM format)")->required();
  cmd.add_option("--align", a.align, "Alignment of EST to GT before comparing")
      ->check(CLI::IsMember({"se3", "sim3", "none"}))
      ->capture_default_str();
  cmd.add_option("--max-dt", a.max_dt, "Maximal timestamp difference for association (s)")
      ->check(non_negative_seconds())
      ->capture_default_str();
  cmd.add_flag("--json", a.json, "Machine-readable output on stdout");
  cmd.add_option("--plot", a.plot, "Write a PNG: top view of both trajectories, error over time");
}

Json stats_json(const eval::ErrorStats& s) {
  return {{"count", s.count}, {"rmse", s.rmse}, {"mean", s.mean}, {"median", s.median},
          {"std", s.std},     {"min", s.min},   {"max", s.max}};
}

void print_stats(const char* what, const char* unit, const eval::ErrorStats& s) {
  std::printf("%s (%s), %zu poses\n", what, unit, s.count);
  std::printf(
      "  rmse   %.6f\n  mean   %.6f\n  median %.6f\n  std    %.6f\n  min    %.6f\n"
      "  max    %.6f\n",
      s.rmse, s.mean, s.median, s.std, s.min, s.max);
}

// The two axes along which the ground truth extends most: the "top view" of a walk.
std::pair<int, int> view_axes(const Trajectory& gt) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300);
  Eigen::Vector3d hi = -lo;
  for (const auto& p : gt) {
    lo = lo.cwiseMin(p.world_from_cam.translation());
    hi = hi.cwiseMax(p.world_from_cam.translation());
  }
  const Eigen::Vector3d span = hi - lo;
  int drop = 0;
  span.minCoeff(&drop);
  const int a = drop == 0 ? 1 : 0;
  const int b = drop == 2 ? 1 : 2;
  return {a, b};
}

Series path_series(const std::string& label, const Trajectory& t, std::pair<int, int> axes,
                   const std::string& colour) {
  Series s{label, {}, colour};
  for (const auto& p : t) {
    const Eigen::Vector3d& x = p.world_from_cam.translation();
    s.points.emplace_back(x(axes.first), x(axes.second));
  }
  return s;
}

Series time_series(const std::string& label, const std::vector<double>& t,
                   const std::vector<double>& v, const std::string& colour) {
  Series s{label, {}, colour};
  for (std::size_t i = 0; i < t.size(); ++i)
    s.points.emplace_back(t[i] - t.front(), v[i]);
  return s;
}

// A file without a single pose is named as such (association would blame the timestamps).
Trajectory read_poses(const std::string& path) {
  Trajectory t = read_tum_trajectory(path);
  if (t.empty()) throw Error("no poses in the file (an empty trajectory)", {.file = path});
  return t;
}

void run_ate(const EvalArgs& a) {
  if (!a.plot.empty()) check_plot_path(a.plot);
  const Trajectory gt = read_poses(a.ground_truth);
  const Trajectory est = read_poses(a.estimate);
  const eval::AteResult r =
      eval::compute_ate(gt, est, {.alignment = eval::parse_alignment(a.align), .max_dt = a.max_dt});
  if (a.json) {
    print_json({{"metric", "ate"},
                {"align", a.align},
                {"scale", r.gt_from_est.scale()},
                {"translation_m", stats_json(r.translation)}});
  } else {
    print_stats("ATE translation", "m", r.translation);
    std::printf("  alignment %s, scale %.6f\n", a.align.c_str(), r.gt_from_est.scale());
  }
  if (!a.plot.empty()) {
    const auto axes = view_axes(r.ground_truth);
    const char names[] = {'x', 'y', 'z'};
    Panel top{"Top view (aligned)",
              std::string(1, names[axes.first]) + " [m]",
              std::string(1, names[axes.second]) + " [m]",
              true,
              {path_series("ground truth", r.ground_truth, axes, "black"),
               path_series("estimate", r.estimate_aligned, axes, "tab:blue")}};
    Panel err{"ATE over time",
              "t [s]",
              "error [m]",
              false,
              {time_series("ATE", r.timestamps, r.errors, "tab:red")}};
    write_plot(a.plot, {top, err});
  }
}

void run_rpe(const EvalArgs& a) {
  if (!a.plot.empty()) check_plot_path(a.plot);
  const Trajectory gt = read_poses(a.ground_truth);
  const Trajectory est = read_poses(a.estimate);
  const eval::RpeResult r = eval::compute_rpe(
      gt, est, {.alignment = eval::parse_alignment(a.align), .max_dt = a.max_dt, .delta = a.delta});
  if (a.json) {
    print_json({{"metric", "rpe"},
                {"align", a.align},
                {"delta", a.delta},
                {"translation_m", stats_json(r.translation)},
                {"rotation_deg", stats_json(r.rotation)}});
  } else {
    print_stats("RPE translation", "m", r.translation);
    print_stats("RPE rotation", "deg", r.rotation);
  }
  if (!a.plot.empty()) {
    Panel t{"RPE translation",
            "t [s]",
            "error [m]",
            false,
            {time_series("translation", r.timestamps, r.translation_errors, "tab:red")}};
    Panel rot{"RPE rotation",
              "t [s]",
              "error [deg]",
              false,
              {time_series("rotation", r.timestamps, r.rotation_errors, "tab:blue")}};
    write_plot(a.plot, {t, rot});
  }
}

}  // namespace

void add_eval_verb(CLI::App& app) {
  CLI::App& eval = *app.add_subcommand("eval", "Trajectory accuracy (TUM / evo definitions)");
  eval.require_subcommand(1);

  auto ate_args = std::make_shared<EvalArgs>();
  CLI::App& ate = *eval.add_subcommand("ate", "Absolute trajectory error");
  add_common(ate, *ate_args, "se3");
  ate.callback([ate_args] { run_ate(*ate_args); });

  auto rpe_args = std::make_shared<EvalArgs>();
  CLI::App& rpe = *eval.add_subcommand("rpe", "Relative pose error");
  add_common(rpe, *rpe_args, "none");
  rpe.add_option("--delta", rpe_args->delta, "Pose pairs (i, i + delta) in associated poses")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  rpe.callback([rpe_args] { run_rpe(*rpe_args); });

  add_frame_limit_verb(eval);
  add_table2_verb(eval);
}

}  // namespace coloc::cli
