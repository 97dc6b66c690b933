// coloc bench loop: what loop closing does to accuracy, per sequence, over several runs with it
// and without it (threads make runs differ: the spread is part of the result). Each accepted
// loop is checked against the ground truth: the relative pose it asserted between its two
// keyframes must agree with the true one, else it is counted as a false loop.

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/slam_inputs.hpp"
#include "Examples/coloc/verbs.hpp"
#include "slam/core/error.hpp"
#include "slam/core/timing.hpp"
#include "slam/pipeline/pipeline.hpp"

namespace coloc::cli {
namespace {

namespace fs = std::filesystem;

// A loop whose asserted relative pose is this far from the truth is false: a true loop's
// verified pose is within centimetres; an aliased place is metres or tens of degrees off.
constexpr double kFalseLoopM = 0.2, kFalseLoopDeg = 5.0;

struct LoopBenchArgs {
  std::vector<fs::path> sequences;
  fs::path config, vocabulary;
  int runs = 3;
  bool concurrent = false;
  bool json = false;
};

struct ModeResult {
  std::vector<double> ate_mm, online_mm, correction_ms;
  int loops = 0, false_loops = 0, rejected = 0, implausible = 0, look_alike = 0, lost = 0;
  int shifted = 0;  // verified poses the current-pose hypothesis moved (a repeating texture)
  double worst_free_space = 0.0;  // the largest free-space violation of a closed loop
  double worst_loop_m = 0.0, worst_loop_deg = 0.0;
};

void add_run(ModeResult& m, const slam::pipeline::RunResult& r, const Trajectory& gt) {
  if (r.ate) m.ate_mm.push_back(1e3 * r.ate->translation.rmse);
  if (r.ate_online) m.online_mm.push_back(1e3 * r.ate_online->translation.rmse);
  const auto& loop = r.summary.loop;
  m.rejected += loop.rejected;
  m.implausible += loop.rejected_aliasing;
  m.look_alike += loop.rejected_look_alike;
  m.shifted += loop.shifted_by_current_pose;
  m.lost += static_cast<int>(r.summary.lost);
  for (const auto& l : loop.loops) {
    ++m.loops;
    m.correction_ms.push_back(l.ms);
    m.worst_free_space = std::max(m.worst_free_space, l.free_space.violation());
    const auto e =
        eval::relative_pose_error(gt, l.current_time, l.candidate_time, l.candidate_from_current);
    if (!e) continue;
    m.worst_loop_m = std::max(m.worst_loop_m, e->translation);
    m.worst_loop_deg = std::max(m.worst_loop_deg, e->rotation_deg);
    if (e->translation > kFalseLoopM || e->rotation_deg > kFalseLoopDeg) ++m.false_loops;
  }
}

Json mode_json(const ModeResult& m) {
  const SampleStats ate = summarize(m.ate_mm);
  return Json{{"runs", m.ate_mm.size()},
              {"ate_mm", m.ate_mm},
              {"ate_mm_median", ate.median},
              {"ate_mm_max", ate.max},
              {"ate_online_mm", m.online_mm},
              {"loops", m.loops},
              {"false_loops", m.false_loops},
              {"rejected", m.rejected},
              {"rejected_implausible", m.implausible},
              {"rejected_look_alike", m.look_alike},
              {"shifted_by_current_pose", m.shifted},
              {"worst_free_space_violation", m.worst_free_space},
              {"correction_ms", m.correction_ms},
              {"worst_loop_error_m", m.worst_loop_m},
              {"worst_loop_error_deg", m.worst_loop_deg},
              {"lost_frames", m.lost}};
}

void print_mode(const char* name, const ModeResult& m) {
  const SampleStats ate = summarize(m.ate_mm), online = summarize(m.online_mm);
  const SampleStats corr = summarize(m.correction_ms);
  std::printf(
      "  %-4s ATE mm: median %.2f, mean %.2f, min %.2f, max %.2f (as tracked: median %.2f) | "
      "loops %d (false %d, worst %.3f m / %.2f deg, depth in free space %.1f %%), rejected %d (%d "
      "implausible, %d by depth), %d shifted to the current pose, correction ms median %.1f max "
      "%.1f | lost frames %d\n",
      name, ate.median, ate.mean, ate.min, ate.max, online.median, m.loops, m.false_loops,
      m.worst_loop_m, m.worst_loop_deg, 100.0 * m.worst_free_space, m.rejected, m.implausible,
      m.look_alike, m.shifted, corr.median, corr.max, m.lost);
}

void run_loop_bench(const LoopBenchArgs& args) {
  const auto vocabulary = load_vocabulary(args.vocabulary);
  Json results = Json::array();
  for (const fs::path& dir : args.sequences) {
    const SlamInputs in = load_slam_inputs(dir, args.config);
    if (in.sequence->ground_truth().empty())
      throw Error("no ground truth: loop closing cannot be judged", {.file = dir.string()});
    ModeResult on, off;
    for (int run = 0; run < args.runs; ++run) {
      for (const bool loop : {true, false}) {
        const slam::pipeline::RunResult r = slam::pipeline::run_slam(
            *in.sequence, in.settings, vocabulary, {.concurrent = args.concurrent, .loop = loop});
        add_run(loop ? on : off, r, in.sequence->ground_truth());
        if (!args.json)
          std::fprintf(stderr, "%s run %d loop %s: ATE %.2f mm, loops %zu\n",
                       dir.filename().string().c_str(), run + 1, loop ? "on" : "off",
                       r.ate ? 1e3 * r.ate->translation.rmse : -1.0, r.summary.loop.loops.size());
      }
    }
    if (args.json) {
      results.push_back(
          {{"sequence", dir.string()}, {"loop_on", mode_json(on)}, {"loop_off", mode_json(off)}});
      continue;
    }
    std::printf("%s (%zu frames, %d runs each, %s)\n", dir.string().c_str(), in.sequence->size(),
                args.runs, slam::pipeline::pacing_name({.concurrent = args.concurrent}));
    print_mode("on", on);
    print_mode("off", off);
  }
  if (args.json) {
    print_json({{"false_loop_bound_m", kFalseLoopM},
                {"false_loop_bound_deg", kFalseLoopDeg},
                {"sequences", results}});
  } else {
    std::printf(
        "ATE: keyframe-anchored trajectory after the final global BA (SE3-aligned RMSE); a loop "
        "is false when\nits asserted relative pose is > %.2f m or > %.1f deg from the truth\n",
        kFalseLoopM, kFalseLoopDeg);
  }
}

}  // namespace

void add_loop_bench_verb(CLI::App& bench) {
  auto args = std::make_shared<LoopBenchArgs>();
  CLI::App* loop = bench.add_subcommand(
      "loop", "Loop closing on / off: ATE over several runs, loops found, false loops");
  loop->add_option("sequences", args->sequences, "Sequence folders (with ground truth)")
      ->required()
      ->check(CLI::ExistingDirectory);
  loop->add_option("--config", args->config,
                   "Camera settings YAML (default: the sequence's camera.yaml, or the shipped "
                   "file for its format)");
  loop->add_option("--vocabulary", args->vocabulary, "BoW vocabulary");
  loop->add_option("--runs", args->runs, "Runs with and without loop closing")
      ->check(CLI::Range(1, 100));
  loop->add_flag("--concurrent", args->concurrent,
                 "Tracking never waits for local mapping (by default it does after each keyframe)");
  loop->add_flag("--json", args->json, "Machine-readable results");
  loop->callback([args] { run_loop_bench(*args); });
}

}  // namespace coloc::cli
