#include "Examples/coloc/camera_source.hpp"

#include <pthread.h>
#include <spdlog/spdlog.h>

#include <ctime>

#include "slam/capture/live_frames.hpp"
#include "slam/capture/replay.hpp"
#include "slam/capture/settings_file.hpp"

namespace coloc::cli {
namespace {

class TimedFrames final : public dataset::FrameSource {
 public:
  TimedFrames(capture::RgbdCamera& camera, double seconds) : live_(camera), seconds_(seconds) {}
  std::optional<dataset::Frame> next() override {
    auto f = live_.next();
    if (!f) return f;
    if (!first_) first_ = f->timestamp;
    if (seconds_ > 0 && f->timestamp - *first_ > seconds_) return std::nullopt;
    return f;
  }

 private:
  capture::LiveFrames live_;
  double seconds_;
  std::optional<double> first_;
};

}  // namespace

CameraSource open_camera_source(const std::string& spec) {
  const std::string prefix = "replay:";
  if (spec.rfind(prefix, 0) == 0)
    return {capture::replay_system(capture::load_replay(spec.substr(prefix.size()))), "auto"};
  return {capture::kernel_system(), spec.empty() ? "auto" : spec};
}

SignalStop::SignalStop(capture::RgbdCamera& camera) {
  thread_ = std::thread([this, &camera] {
    const sigset_t set = stop_signals();
    const timespec tick{0, 100000000};
    while (!done_) {
      const int signal = sigtimedwait(&set, nullptr, &tick);
      if (signal <= 0) continue;
      if (!interrupted_) {
        interrupted_ = true;
        camera.stop();  // the verb ends cleanly, everything written
        continue;
      }
      // A second one: the verb did not end (a stuck write, a busy step). The user asked twice:
      // the default action ends the process.
      struct sigaction default_action {};
      default_action.sa_handler = SIG_DFL;
      sigaction(signal, &default_action, nullptr);
      sigset_t one;
      sigemptyset(&one);
      sigaddset(&one, signal);
      pthread_sigmask(SIG_UNBLOCK, &one, nullptr);
      ::raise(signal);
    }
  });
}

SignalStop::~SignalStop() {
  done_ = true;
  thread_.join();
}

LiveInput open_live_input(const std::string& camera, const std::filesystem::path& calibration,
                          const std::string& mode, const std::filesystem::path& config,
                          const std::filesystem::path& settings_path) {
  LiveInput in;
  in.source = open_camera_source(camera);
  capture::CameraOptions o;
  o.device = in.source.device;
  o.calibration_file = calibration;
  if (!mode.empty()) capture::parse_mode(mode, o);
  in.camera = std::make_unique<capture::RgbdCamera>(*in.source.system, o);
  in.config = config;
  if (in.config.empty()) {
    in.config = settings_path;
    capture::write_settings_file(
        in.config, {.camera = in.camera->color_camera(),
                    .fps = o.color.fps,
                    .depth_map_factor = 1.0,  // LiveFrames hands depth in metres
                    .baseline_m = in.camera->calibration().baseline_m,
                    .comment = "# " + in.camera->device().model + " " + in.camera->device().serial +
                               ": colour camera of the live input"});
    spdlog::info("live camera settings written to {}", in.config.string());
  }
  in.settings = settings::load_settings(in.config);
  return in;
}

std::unique_ptr<dataset::FrameSource> live_frames(capture::RgbdCamera& camera, double seconds) {
  return std::make_unique<TimedFrames>(camera, seconds);
}

CaptureLosses end_live(capture::RgbdCamera& camera) {
  camera.stop();
  if (camera.unplugged())
    spdlog::warn("the camera was lost: {}; what came before was used",
                 camera.end_reason().value_or(""));
  const capture::CaptureStats s = camera.stats();
  const CaptureLosses lost{.driver_drops = s.depth.kernel_drops + s.color.kernel_drops,
                           .queue_drops = s.depth.queue_drops + s.color.queue_drops,
                           .unpaired = s.pairing.unpaired_depth + s.pairing.unpaired_color};
  if (lost.total() > 0)
    spdlog::warn(
        "frames lost on the way from the camera: {} skipped by the driver, {} dropped while "
        "SLAM was behind, {} without a partner",
        lost.driver_drops, lost.queue_drops, lost.unpaired);
  return lost;
}

}  // namespace coloc::cli
