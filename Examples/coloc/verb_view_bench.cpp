// coloc bench view SEQ: what live viewing costs tracking. The same sequence is mapped without a
// viewer, with the viewer's server and feed attached but no page open, and with a page
// connected (a program that reads the event stream and fetches the scene and every pushed image
// as the page does); tracking ms/frame (extraction included, the tracking thread) per mode.

#include <cstdio>
#include <memory>

#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/slam_inputs.hpp"
#include "Examples/coloc/verbs.hpp"
#include "Examples/coloc/view_session.hpp"
#include "slam/core/error.hpp"
#include "slam/pipeline/pipeline.hpp"
#include "slam/view/client.hpp"

namespace coloc::cli {
namespace {

namespace fs = std::filesystem;

struct ViewBenchArgs {
  fs::path sequence, config, vocabulary;
  int runs = 1;
  bool sequential = false;
  bool json = false;
  ViewArgs view;
};

enum class Mode { kOff, kIdle, kConnected };
const char* mode_name(Mode m) {
  return m == Mode::kOff ? "no viewer" : m == Mode::kIdle ? "viewer, no page" : "page connected";
}

struct ModeResult {
  SampleStats ms;
  slam::view::LiveFeedStats feed;
  HookStats hook;
  slam::view::EventClientStats page;
  std::uint64_t dropped = 0;  // events dropped for the page
};

ModeResult run_mode(const ViewBenchArgs& a, const SlamInputs& in,
                    const slam::bow::Vocabulary& vocabulary, Mode mode) {
  slam::pipeline::RunOptions run{.sequential = a.sequential, .concurrent = !a.sequential};
  ModeResult out;
  std::unique_ptr<slam::view::ViewServer> server;
  std::unique_ptr<LiveSystemView> live;
  std::unique_ptr<slam::view::EventClient> page;
  if (mode != Mode::kOff) {
    ViewArgs v = a.view;
    v.port = 0;  // runs must not collide with a viewer the user has open
    server = start_view_server(v, {}, true);
    live = std::make_unique<LiveSystemView>(*server, v, fs::path());
    run.on_start = [&](slam::system::System& s) {
      live->attach(s);
      if (mode != Mode::kConnected) return;
      page = std::make_unique<slam::view::EventClient>("127.0.0.1", server->port());
      if (!server->wait_for_client(5.0)) throw CliFailure("the benchmark's page did not connect");
    };
    run.on_stop = [&] { live->detach(); };
  }
  const slam::pipeline::RunResult r = slam::pipeline::run_slam(
      *in.sequence, in.settings, vocabulary, run, [&](const slam::system::System& s) {
        if (live) live->finish(s);
      });
  out.ms = r.summary.total_ms;
  if (live) {
    out.feed = live->stats();
    out.hook = live->hook();
  }
  if (page) {
    out.page = page->stats();
    page->disconnect();
  }
  if (server) out.dropped = server->stats().events_dropped;
  return out;
}

void run_bench(const ViewBenchArgs& a) {
  const SlamInputs in = load_slam_inputs(a.sequence, a.config);
  const slam::bow::Vocabulary vocabulary = load_vocabulary(a.vocabulary);
  std::printf("sequence %s (%zu frames), %s mapping, live view at most %.1f frames/s\n",
              a.sequence.string().c_str(), in.sequence->size(),
              a.sequential ? "sequential" : "concurrent", a.view.max_fps);
  std::printf("%4s %-16s %7s %7s %7s %8s %8s %9s %6s %5s %7s %9s %9s %7s\n", "run", "mode",
              "ms_med", "ms_p99", "ms_max", "hook_us", "hook_max", "hook_wall", "pushed", "maps",
              "page_fr", "map_lk_ms", "encode_ms", "dropped");
  Json rows = Json::array();
  for (int run = 0; run < a.runs; ++run) {
    for (Mode mode : {Mode::kOff, Mode::kIdle, Mode::kConnected}) {
      const ModeResult m = run_mode(a, in, vocabulary, mode);
      const double hook_us =
          m.hook.frames ? 1e3 * m.hook.cpu_total_ms / static_cast<double>(m.hook.frames) : 0.0;
      std::printf(
          "%4d %-16s %7.2f %7.2f %7.2f %8.1f %8.1f %9.1f %6llu %5llu %7llu %9.2f %9.2f %7llu\n",
          run + 1, mode_name(mode), m.ms.median, m.ms.p99, m.ms.max, hook_us,
          1e3 * m.hook.cpu_max_ms, 1e3 * m.hook.max_ms,
          static_cast<unsigned long long>(m.feed.frames_published),
          static_cast<unsigned long long>(m.feed.map_snapshots),
          static_cast<unsigned long long>(m.page.frames), m.feed.max_map_copy_ms,
          m.feed.max_encode_ms, static_cast<unsigned long long>(m.dropped));
      rows.push_back({{"run", run + 1},
                      {"mode", mode_name(mode)},
                      {"ms_per_frame_median", m.ms.median},
                      {"ms_per_frame_p99", m.ms.p99},
                      {"hook_us_mean", hook_us},
                      {"hook_us_max", 1e3 * m.hook.cpu_max_ms},
                      {"hook_wall_us_max", 1e3 * m.hook.max_ms},
                      {"frames_pushed", m.feed.frames_published},
                      {"page_frames", m.page.frames},
                      {"map_snapshots", m.feed.map_snapshots},
                      {"max_map_copy_ms", m.feed.max_map_copy_ms}});
    }
  }
  std::printf(
      "ms: tracking thread per frame (extraction + tracking, wall time)\n"
      "hook_us / hook_max: mean / longest CPU microseconds per frame that the tracking thread\n"
      "  spent in the viewer's hook (the frame snapshot included); hook_wall: longest wall time\n"
      "  in it (preemption included)\n"
      "pushed: frames the feed sent; maps: map snapshots; page_fr: frames the page received\n"
      "map_lk_ms: longest map snapshot (waiting for the map lock included)\n"
      "encode_ms: longest JPEG encoding (feed thread); dropped: events dropped for the page\n");
  if (a.json) print_json(rows);
}

}  // namespace

void add_view_bench_verb(CLI::App& bench) {
  auto a = std::make_shared<ViewBenchArgs>();
  CLI::App* cmd = bench.add_subcommand(
      "view", "Tracking ms/frame without a viewer, with one, with a page open");
  cmd->add_option("sequence", a->sequence, "Sequence folder")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--config", a->config, "Camera settings YAML");
  cmd->add_option("--vocabulary", a->vocabulary, "BoW vocabulary");
  cmd->add_option("--runs", a->runs, "Runs of the three modes")->check(CLI::Range(1, 100));
  cmd->add_option("--fps", a->view.max_fps, "Live frames pushed per second")
      ->check(CLI::Range(0.1, 100.0));
  cmd->add_flag("--sequential", a->sequential, "Tracking waits for local mapping");
  cmd->add_flag("--json", a->json, "Rows as JSON after the table");
  cmd->callback([a] { run_bench(*a); });
}

}  // namespace coloc::cli
