// coloc scan from-sequence SEQ --out CLOUD.ply|.e57: a posed RGB-D recording fused into a
// coloured cloud in its ground truth's frame (registration/align/sequence_cloud.hpp), so a
// real recording with ground truth can stand in for a laser scan of its scene.
#include <cstdio>
#include <memory>

#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/slam_inputs.hpp"
#include "Examples/coloc/verbs.hpp"
#include "registration/align/sequence_cloud.hpp"
#include "slam/core/atomic_file.hpp"
#include "slam/core/error.hpp"
#include "slam/core/row_progress.hpp"
#include "slam/core/timing.hpp"

namespace coloc::cli {
namespace {

struct FromSequenceArgs {
  std::filesystem::path sequence, out, config;
  registration::align::SequenceCloudOptions options;
  bool json = false;
};

void run_from_sequence(const FromSequenceArgs& a) {
  a.options.check();
  if (a.out.extension() != ".ply" && a.out.extension() != ".e57")
    throw Error("the output must end in .ply or .e57", {.file = a.out.string(), .field = "--out"});
  { const AtomicFile probe(a.out); }  // an unwritable output fails before the work
  const SlamInputs in = load_slam_inputs(a.sequence, a.config);
  Stopwatch watch;
  registration::align::SequenceCloudStats stats;
  RowProgress progress("fusing frames", a.json);
  const registration::render::PointCloud cloud = registration::align::fuse_sequence(
      *in.sequence, in.settings.camera, a.options, &stats, progress.callback());
  progress.finish();
  registration::align::write_point_cloud(
      a.out, cloud,
      "coloc scan from-sequence " + a.sequence.filename().string() + ", ground-truth frame");
  if (a.json) {
    print_json({{"frames_used", stats.frames_used},
                {"frames_without_pose", stats.frames_without_pose},
                {"frames_unreadable", stats.frames_unreadable},
                {"depth_points", stats.depth_points},
                {"points", cloud.points.size()},
                {"seconds", watch.elapsed_seconds()}});
    return;
  }
  std::printf(
      "%zu frames fused (%zu without a ground-truth pose, %zu unreadable), %llu depth points "
      "-> %zu points of %.3f m voxels in %.1f s; written to %s\n",
      stats.frames_used, stats.frames_without_pose, stats.frames_unreadable,
      static_cast<unsigned long long>(stats.depth_points), cloud.points.size(),
      a.options.voxel_size, watch.elapsed_seconds(), a.out.c_str());
}

}  // namespace

void add_scan_verb(CLI::App& app) {
  CLI::App& scan = *app.add_subcommand("scan", "Point clouds that stand in for a laser scan");
  scan.require_subcommand(1);
  auto a = std::make_shared<FromSequenceArgs>();
  CLI::App& cmd = *scan.add_subcommand(
      "from-sequence",
      "Fuse a posed RGB-D sequence (its ground truth) into a coloured cloud (.ply or .e57)");
  cmd.add_option("sequence", a->sequence, "Sequence folder with ground truth (TUM, 7-Scenes, twin)")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd.add_option("--out", a->out, "Output cloud: .ply or .e57")->required();
  cmd.add_option("--config", a->config,
                 "Camera settings (default: the sequence's camera.yaml or the shipped file)")
      ->check(CLI::ExistingFile);
  cmd.add_option("--every", a->options.every, "One frame in N")->capture_default_str();
  cmd.add_option("--voxel", a->options.voxel_size, "Voxel size (m)")->capture_default_str();
  cmd.add_option("--max-depth", a->options.max_depth, "Depth beyond this is not used (m)")
      ->capture_default_str();
  cmd.add_flag("--json", a->json, "Machine-readable summary on stdout");
  cmd.callback([a] { run_from_sequence(*a); });
}

}  // namespace coloc::cli
