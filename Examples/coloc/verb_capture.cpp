// coloc devices: the RealSense cameras attached (V4L2 nodes grouped per USB device, each node's
// role); coloc devices make-replay: a replay description from a recorded sequence (to try
// record/map/localize without a camera); coloc bench capture: decode + registration cost per
// pair and the recorder's write rate (slam/capture/bench.hpp).
#include <cstdio>
#include <iostream>

#include "Examples/coloc/camera_source.hpp"
#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/slam_inputs.hpp"
#include "Examples/coloc/verbs.hpp"
#include "slam/capture/bench.hpp"
#include "slam/capture/discovery.hpp"
#include "slam/capture/formats.hpp"
#include "slam/capture/replay_build.hpp"

namespace coloc::cli {
namespace {

namespace fs = std::filesystem;

std::string modes_text(const capture::DiscoveredNode& n) {
  std::string s;
  for (const auto& f : n.formats) {
    if (!s.empty()) s += "; ";
    s += capture::fourcc_name(f.fourcc);
    for (const auto& size : f.sizes) {
      s += ' ';
      s += std::to_string(size.width);
      s += 'x';
      s += std::to_string(size.height);
      s += '@';
      for (std::size_t i = 0; i < size.fps.size(); ++i) {
        if (i > 0) s += '/';
        s += std::to_string(static_cast<int>(size.fps[i]));
      }
    }
  }
  return s;
}

Json devices_json(const capture::Discovery& d) {
  Json devices = Json::array();
  for (const auto& dev : d.devices) {
    Json nodes = Json::array();
    for (const auto& n : dev.nodes) {
      Json formats = Json::array();
      for (const auto& f : n.formats) {
        Json sizes = Json::array();
        for (const auto& s : f.sizes)
          sizes.push_back({{"width", s.width}, {"height", s.height}, {"fps", s.fps}});
        formats.push_back({{"fourcc", capture::fourcc_name(f.fourcc)}, {"sizes", sizes}});
      }
      nodes.push_back({{"device", n.info.device.string()},
                       {"kind", capture::kind_name(n.kind)},
                       {"formats", formats},
                       {"error", n.error.empty() ? Json() : Json(n.error)}});
    }
    devices.push_back({{"model", dev.model},
                       {"serial", dev.serial},
                       {"usb_speed_mbps", dev.speed},
                       {"usb3", dev.usb3()},
                       {"nodes", nodes}});
  }
  return {{"video_nodes", d.video_nodes}, {"devices", devices}};
}

void run_devices(const std::string& camera, bool json) {
  CameraSource src = open_camera_source(camera.empty() ? "auto" : camera);
  const capture::Discovery d = capture::discover(*src.system);
  if (json) {
    print_json(devices_json(d));
  } else {
    for (const auto& dev : d.devices) {
      std::printf("%s serial %s, USB %s Mbit/s%s\n", dev.model.c_str(), dev.serial.c_str(),
                  dev.speed.c_str(), dev.usb3() ? "" : "  (not USB 3: expect drops)");
      for (const auto& n : dev.nodes)
        std::printf("  %-12s %-9s %s%s\n", n.info.device.c_str(),
                    capture::kind_name(n.kind).c_str(), modes_text(n).c_str(),
                    n.error.empty() ? "" : ("  ! " + n.error).c_str());
    }
  }
  if (d.devices.empty()) {
    if (!json) std::cerr << capture::no_camera_advice(d) << "\n";
    throw CliFailure("no RealSense camera attached");
  }
}

struct MakeReplayArgs {
  fs::path sequence, config, out;
  std::size_t frames = 0;
  int unplug_after = -1;
  bool unpaced = false;
};

void run_make_replay(const MakeReplayArgs& a) {
  const SlamInputs in = load_slam_inputs(a.sequence, a.config);
  const auto* pinhole = std::get_if<PinholeCamera>(&in.settings.camera);
  if (pinhole == nullptr || pinhole->width <= 0)
    throw Error("make-replay needs a pinhole camera with Camera.width/height",
                {.file = in.config.string()});
  capture::ReplayBuildOptions o{.frames = a.frames, .realtime = !a.unpaced};
  if (a.unplug_after >= 0) o.unplug_after = static_cast<std::size_t>(a.unplug_after);
  const capture::ReplayDescription d = capture::replay_from_sequence(*in.sequence, *pinhole, o);
  capture::save_replay(d, a.out);
  std::printf("replay of %zu frames (%dx%d) -> %s; use --camera replay:%s\n",
              d.nodes[0].frames.size(), pinhole->width, pinhole->height, a.out.c_str(),
              a.out.c_str());
}

void print_stats(const char* name, const SampleStats& s) {
  std::printf("  %-22s median %6.3f ms  p99 %6.3f ms\n", name, s.median, s.p99);
}

void run_bench(int pairs, const fs::path& out, std::size_t frames, unsigned workers) {
  const capture::DecodeBench b = capture::measure_decode_register(pairs);
  std::printf("decode + register, %dx%d Z16 + %dx%d YUYV, %d pairs (thread CPU time, one core):\n",
              b.depth_width, b.depth_height, b.color_width, b.color_height, pairs);
  print_stats("Z16 decode", b.z16_ms);
  print_stats("YUYV -> BGR", b.yuyv_ms);
  print_stats("register to colour", b.register_ms);
  print_stats("total per pair", b.total_ms);
  if (frames == 0) return;
  const capture::WriteBench w = capture::measure_recorder(out, frames, workers);
  std::printf(
      "recorder: %zu pairs of 640x480 PNGs in %.2f s with %u PNG workers: %.1f pairs/s, "
      "%.1f MB/s -> %s\n",
      w.frames, w.seconds, w.workers, w.frames_per_second, w.megabytes_per_second, out.c_str());
}

}  // namespace

void add_capture_verb(CLI::App& app, CLI::App& bench) {
  auto camera = std::make_shared<std::string>("auto");
  auto json = std::make_shared<bool>(false);
  CLI::App* devices = app.add_subcommand(
      "devices", "RealSense D4xx cameras attached over V4L2 (nodes, roles, modes)");
  devices->add_option("--camera", *camera, "auto, /dev/videoN or replay:DIR");
  devices->add_flag("--json", *json, "Machine-readable list");
  auto mr = std::make_shared<MakeReplayArgs>();
  CLI::App* make = devices->add_subcommand(
      "make-replay", "A replay description (a camera that is not there) from a sequence");
  make->add_option("--sequence", mr->sequence, "TUM / twin sequence (640x480 or 848x480)")
      ->required()
      ->check(CLI::ExistingDirectory);
  make->add_option("--config", mr->config, "Camera settings (default: the sequence's)");
  make->add_option("--out", mr->out, "Replay folder")->required();
  make->add_option("--frames", mr->frames, "Only the first N frames");
  make->add_option("--unplug-after", mr->unplug_after, "The camera disappears after N frames");
  make->add_flag("--unpaced", mr->unpaced,
                 "Serve frames when the reader takes them, losing none however slow it is "
                 "(default: at their timestamps' pace, as a camera does, dropping what a slow "
                 "reader cannot take)");
  make->callback([mr] { run_make_replay(*mr); });
  devices->callback([devices, make, camera, json] {
    if (devices->got_subcommand(make)) return;
    run_devices(*camera, *json);
  });

  auto pairs = std::make_shared<int>(300);
  auto out = std::make_shared<fs::path>(fs::temp_directory_path() / "coloc_bench_capture");
  auto frames = std::make_shared<std::size_t>(150);
  auto workers = std::make_shared<unsigned>(2);
  CLI::App* b =
      bench.add_subcommand("capture", "Decode + registration per pair, recorder write rate");
  b->add_option("--pairs", *pairs, "Decode pairs")->check(CLI::Range(1, 100000));
  b->add_option("--write-frames", *frames, "Pairs the recorder writes (0: skip)");
  b->add_option("--workers", *workers, "PNG workers")->check(CLI::Range(1, 16));
  b->add_option("--out", *out, "Where the recorder writes (removed first)");
  b->callback([=] {
    if (*frames > 0) fs::remove_all(*out);
    run_bench(*pairs, *out, *frames, *workers);
  });
}

}  // namespace coloc::cli
