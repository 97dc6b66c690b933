// coloc record: a live RGB-D sequence from a RealSense D4xx (or a replay) written in the TUM
// layout, with a live status line on stderr; Ctrl-C (SIGINT) or SIGTERM ends it cleanly with
// everything written.
#include <spdlog/spdlog.h>

#include <cstdio>

#include "Examples/coloc/camera_source.hpp"
#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/verbs.hpp"
#include "slam/capture/camera.hpp"
#include "slam/capture/iio.hpp"
#include "slam/capture/recorder.hpp"

namespace coloc::cli {
namespace {

namespace fs = std::filesystem;

struct RecordArgs {
  fs::path out, calibration;
  std::string camera = "auto";
  std::string mode;
  double seconds = 0.0;
  unsigned workers = 2;
  bool json = false;
  bool no_imu = false;
};

// The camera's accelerometer and gyroscope over iio, when the camera has them (D455, D435i)
// and they can be opened; without them the recording goes on with a warning.
std::unique_ptr<capture::ImuStream> open_imu(const capture::RgbdCamera& camera, bool disabled) {
  if (disabled) return nullptr;
  const auto sensors = capture::find_iio_imu("/sys/bus/iio/devices", camera.device().usb_path);
  if (sensors.size() != 2) {
    spdlog::info("no IMU found below {} (iio accel_3d + gyro_3d): imu.txt stays empty",
                 camera.device().usb_path);
    return nullptr;
  }
  try {
    return std::make_unique<capture::ImuStream>(sensors[0], sensors[1]);
  } catch (const Error& e) {
    spdlog::warn("IMU not recorded: {}", e.what());
    return nullptr;
  }
}

// The live line: frame rates over the last interval, and every drop so far.
class StatusLine {
 public:
  void print(const capture::RgbdCamera& camera, const capture::Recorder& recorder, double t) {
    const capture::CaptureStats s = camera.stats();
    const double dt = std::max(t - last_t_, 1e-3);
    std::fprintf(stderr,
                 "\r%6.1f s  depth %5.1f fps  colour %5.1f fps  pairs %zu  written %zu  drops: "
                 "driver %zu/%zu queue %zu/%zu unpaired %zu/%zu   ",
                 t, static_cast<double>(s.depth.frames - last_.depth.frames) / dt,
                 static_cast<double>(s.color.frames - last_.color.frames) / dt, s.pairing.pairs,
                 recorder.stats().written, s.depth.kernel_drops, s.color.kernel_drops,
                 s.depth.queue_drops, s.color.queue_drops, s.pairing.unpaired_depth,
                 s.pairing.unpaired_color);
    last_ = s;
    last_t_ = t;
  }

 private:
  capture::CaptureStats last_;
  double last_t_ = 0.0;
};

void run_record(const RecordArgs& a) {
  block_stop_signals();
  CameraSource src = open_camera_source(a.camera);
  capture::CameraOptions o;
  o.device = src.device;
  o.calibration_file = a.calibration;
  if (!a.mode.empty()) capture::parse_mode(a.mode, o);
  capture::RgbdCamera camera(*src.system, o);
  const capture::RealSenseDevice& dev = camera.device();
  capture::SettingsFileContent settings{
      .camera = camera.color_camera(),
      .fps = o.color.fps,
      .depth_map_factor = o.depth_units_per_metre,
      .baseline_m = camera.calibration().baseline_m,
      .comment = "# coloc record: " + dev.model + " serial " + dev.serial + ", colour camera (" +
                 (a.calibration.empty() ? "factory calibration" : a.calibration.string()) +
                 "); depth registered to it."};
  capture::Recorder recorder(a.out, settings, {.png_workers = a.workers});
  std::unique_ptr<capture::ImuStream> imu = open_imu(camera, a.no_imu);
  const SignalStop signals(camera);
  std::optional<double> first;
  double last_status = 0.0, elapsed = 0.0;
  StatusLine status;
  while (auto f = camera.next()) {
    if (!first) first = f->timestamp;
    elapsed = f->timestamp - *first;
    if (a.seconds > 0 && elapsed > a.seconds) break;
    recorder.add(*f);
    if (imu)
      for (dataset::ImuSample s : imu->take()) {
        s.timestamp = camera.frame_time_of_host(s.timestamp);
        recorder.add_imu(s);
      }
    if (!a.json && elapsed - last_status >= 1.0) {
      status.print(camera, recorder, elapsed);
      last_status = elapsed;
    }
  }
  camera.stop();
  if (imu) imu->stop();
  recorder.close();
  if (!a.json && last_status > 0.0) std::fprintf(stderr, "\n");
  const capture::CaptureStats s = camera.stats();
  const auto reason = camera.end_reason();
  if (a.json) {
    print_json({{"out", a.out.string()},
                {"model", dev.model},
                {"pairs", recorder.stats().written},
                {"seconds", elapsed},
                {"depth_frames", s.depth.frames},
                {"color_frames", s.color.frames},
                {"driver_drops", s.depth.kernel_drops + s.color.kernel_drops},
                {"queue_drops", s.depth.queue_drops + s.color.queue_drops},
                {"unpaired", s.pairing.unpaired_depth + s.pairing.unpaired_color},
                {"metadata_missing", s.metadata_missing},
                {"imu_samples", recorder.stats().imu_samples},
                {"imu_dropped", imu ? imu->dropped() : 0},
                {"interrupted", signals.interrupted()},
                {"unplugged", camera.unplugged()}});
  } else {
    std::printf("recorded %zu RGB-D pairs (%.1f s) from %s into %s\n", recorder.stats().written,
                elapsed, dev.model.c_str(), a.out.c_str());
  }
  if (camera.unplugged())
    throw CliFailure("the camera was lost: " + reason.value_or("") +
                     "; the recording so far is complete in " + a.out.string());
}

}  // namespace

void add_record_verb(CLI::App& app) {
  auto a = std::make_shared<RecordArgs>();
  CLI::App* cmd = app.add_subcommand(
      "record", "Record a RealSense D4xx (V4L2, no librealsense) as a TUM RGB-D sequence");
  cmd->add_option("--out", a->out, "Output folder (rgb/, depth/, rgb.txt, depth.txt, camera.yaml)")
      ->required();
  cmd->add_option("--camera", a->camera, "auto, /dev/videoN of the camera, or replay:DIR");
  cmd->add_option("--seconds", a->seconds, "Stop after this long (default: Ctrl-C)");
  cmd->add_option("--mode", a->mode,
                  "depth=WxH@FPS,color=WxH@FPS (default depth=848x480@30,color=640x480@30)");
  // No CLI::ExistingFile: the calibration reader checks the path (a FIFO, a directory) and
  // fails with exit 1 naming it.
  cmd->add_option("--calibration", a->calibration,
                  "Camera YAML instead of the factory calibration (e.g. from coloc calibrate)");
  cmd->add_option("--workers", a->workers, "PNG encoding threads")->check(CLI::Range(1, 16));
  cmd->add_flag("--no-imu", a->no_imu, "Do not record the IMU (iio accel_3d / gyro_3d)");
  cmd->add_flag("--json", a->json, "Machine-readable summary (no status line)");
  cmd->callback([a] { run_record(*a); });
}

}  // namespace coloc::cli
