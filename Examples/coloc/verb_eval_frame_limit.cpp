// coloc eval frame-limit SEQ: what the data allow any frame-to-frame tracker (each frame's pose
// solved from the previous frame placed at its ground truth); the measurement is
// coloc::eval::measure_frame_limit (slam/eval/frame_limit.hpp).

#include <cstdio>

#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/slam_inputs.hpp"
#include "Examples/coloc/verbs.hpp"
#include "slam/core/progress.hpp"
#include "slam/eval/frame_limit.hpp"

namespace coloc::cli {
namespace {

namespace fs = std::filesystem;

struct FrameLimitArgs {
  fs::path sequence, config;
  eval::FrameLimitOptions options;
  double readout = -1.0;  // seconds; < 0: the settings' Camera.readoutTime
  bool json = false;
};

void print_text(const eval::FrameLimitResult& r) {
  std::printf(
      "frame-to-frame limit over %zu frame pairs (previous frame at its ground-truth pose), "
      "rolling-shutter readout %.1f ms\n",
      r.pairs.size(), 1e3 * r.readout);
  std::printf("  rotation    rms %.3f deg, median %.3f, max %.3f\n", r.rotation_deg.rmse,
              r.rotation_deg.median, r.rotation_deg.max);
  std::printf("  translation rms %.1f mm, median %.1f, max %.1f\n", r.translation_mm.rmse,
              r.translation_mm.median, r.translation_mm.max);
  std::printf("  inliers     median %.0f, min %.0f\n", r.inliers.median, r.inliers.min);
  std::printf("  worst frames (index: translation mm):");
  for (const eval::FramePairError& p : r.worst(8))
    std::printf(" %zu: %.1f", p.frame, p.translation_mm);
  std::printf("\n");
}

void run_frame_limit(FrameLimitArgs args) {
  if (args.readout >= 0.0) args.options.readout = args.readout;
  const SlamInputs in = load_slam_inputs(args.sequence, args.config);
  Progress progress("frame-limit", in.sequence->size(), args.json);
  const eval::FrameLimitResult r =
      eval::measure_frame_limit(*in.sequence, in.settings, args.options,
                                [&progress](std::size_t done, std::size_t) { progress.set(done); });
  progress.finish();
  if (!args.json) {
    print_text(r);
    return;
  }
  print_json({{"pairs", r.pairs.size()},
              {"rotation_deg_rms", r.rotation_deg.rmse},
              {"rotation_deg_median", r.rotation_deg.median},
              {"rotation_deg_max", r.rotation_deg.max},
              {"translation_mm_rms", r.translation_mm.rmse},
              {"translation_mm_median", r.translation_mm.median},
              {"translation_mm_max", r.translation_mm.max},
              {"inliers_median", r.inliers.median},
              {"readout_s", r.readout}});
}

}  // namespace

void add_frame_limit_verb(CLI::App& eval) {
  auto args = std::make_shared<FrameLimitArgs>();
  CLI::App& cmd = *eval.add_subcommand(
      "frame-limit",
      "Error of a frame's pose solved from the previous frame placed at its ground truth: what "
      "the data allow any frame-to-frame tracker");
  cmd.add_option("sequence", args->sequence, "Sequence folder with ground truth")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd.add_option("--config", args->config, "Camera settings YAML (default: shipped file)");
  cmd.add_option("--window", args->options.window_px, "Match search window (pixels)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd.add_option("--readout", args->readout,
                 "Rolling-shutter readout time in seconds (default: Camera.readoutTime; 0 = off)")
      ->check(CLI::Range(0.0, 0.5));
  cmd.add_flag("--json", args->json, "Machine-readable output on stdout");
  cmd.callback([args] { run_frame_limit(*args); });
}

}  // namespace coloc::cli
