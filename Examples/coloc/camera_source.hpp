#pragma once
// What `--camera` names for the capture verbs (devices, record, map, localize): `auto` (the
// first RealSense found), a /dev/videoN of the camera, or `replay:DIR` (a recorded replay
// description, see slam/capture/replay.hpp) for trying everything without a camera. And what
// the live verbs share: Ctrl-C ending a live session cleanly, a time limit, and the settings
// that the camera's calibration gives.
#include <signal.h>

#include <atomic>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>

#include "Examples/coloc/stop_signals.hpp"
#include "slam/capture/camera.hpp"
#include "slam/capture/device.hpp"
#include "slam/dataset/frame_source.hpp"
#include "slam/settings/settings.hpp"

namespace coloc::cli {

struct CameraSource {
  std::unique_ptr<capture::DeviceSystem> system;
  std::string device;  // what RgbdCamera / find_camera get
};

CameraSource open_camera_source(const std::string& spec);

// Waits for SIGINT/SIGTERM (blocked by block_stop_signals) and stops the camera; a second
// signal, when the verb did not end (busy or stuck), ends the process by the signal's default
// action. Ends when destroyed. Signals are taken by sigtimedwait: no handler, no global state.
class SignalStop {
 public:
  explicit SignalStop(capture::RgbdCamera& camera);
  ~SignalStop();
  SignalStop(const SignalStop&) = delete;
  SignalStop& operator=(const SignalStop&) = delete;
  bool interrupted() const { return interrupted_; }

 private:
  std::atomic<bool> done_{false}, interrupted_{false};
  std::thread thread_;
};

// A live camera opened for the SLAM verbs, with the settings its calibration gives (written to
// `settings_path` as an ORB-SLAM3 v1.0 file, then loaded like any settings file) unless
// `config` names a settings file to use instead.
struct LiveInput {
  CameraSource source;
  std::unique_ptr<capture::RgbdCamera> camera;
  std::filesystem::path config;
  settings::Settings settings;
};
LiveInput open_live_input(const std::string& camera, const std::filesystem::path& calibration,
                          const std::string& mode, const std::filesystem::path& config,
                          const std::filesystem::path& settings_path);

// The frames of `camera` for at most `seconds` (0: until the camera stops).
std::unique_ptr<dataset::FrameSource> live_frames(capture::RgbdCamera& camera, double seconds);

// What a live run lost on the way from the camera: frames the driver skipped, frames dropped
// because SLAM was behind (a full queue), and frames left without a partner.
struct CaptureLosses {
  std::size_t driver_drops = 0, queue_drops = 0, unpaired = 0;
  std::size_t total() const { return driver_drops + queue_drops + unpaired; }
};

// Stops `camera` after a live run and warns of what was lost: the camera itself (unplugged)
// or frames on the way. Call from the thread that read the frames, after the reading ended.
CaptureLosses end_live(capture::RgbdCamera& camera);

}  // namespace coloc::cli
