#include "slam/capture/recorder.hpp"

#include <spdlog/spdlog.h>

#include <cstdio>
#include <opencv2/imgcodecs.hpp>

namespace coloc::capture {
namespace fs = std::filesystem;
namespace {

const char* const kLists[] = {"rgb.txt", "depth.txt", "imu.txt"};

std::ofstream open_list(const fs::path& path, const std::string& header) {
  std::ofstream out(path);
  if (!out) throw Error("cannot write", {.file = path.string()});
  out << header;
  return out;
}

std::string stamp(double t) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.6f", t);
  return buf;
}

}  // namespace

void RecorderOptions::check() const {
  if (png_workers == 0) throw Error("must be at least 1", {.field = "png_workers"});
  if (queue_capacity == 0) throw Error("must be at least 1", {.field = "queue_capacity"});
  if (png_compression < 0 || png_compression > 9)
    throw Error("must be 0..9", {.field = "png_compression"});
}

Recorder::Recorder(fs::path dir, SettingsFileContent camera, RecorderOptions options)
    : dir_(std::move(dir)),
      camera_(std::move(camera)),
      options_(options),
      jobs_(options.queue_capacity) {
  options_.check();
  if (fs::exists(dir_ / "rgb.txt") || fs::exists(dir_ / "rgb.txt.partial"))
    throw Error("already holds a recording; choose another --out", {.file = dir_.string()});
  std::error_code ec;
  fs::create_directories(dir_ / "rgb", ec);
  fs::create_directories(dir_ / "depth", ec);
  if (ec || !fs::is_directory(dir_ / "depth"))
    throw Error("cannot create the output folder: " + ec.message(), {.file = dir_.string()});
  rgb_list_ = open_list(dir_ / "rgb.txt.partial", "# color images\n# timestamp filename\n");
  depth_list_ = open_list(dir_ / "depth.txt.partial", "# depth images\n# timestamp filename\n");
  imu_list_ = open_list(dir_ / "imu.txt.partial",
                        "# timestamp[s] gx gy gz [rad/s] ax ay az [m/s^2], IMU frame\n");
  for (unsigned i = 0; i < options_.png_workers; ++i)
    workers_.emplace_back([this] { work(); });
}

Recorder::~Recorder() {
  try {
    close();
  } catch (const std::exception& e) {
    spdlog::error("recorder: {}", e.what());
  }
}

void Recorder::work() {
  while (auto job = jobs_.pop()) {
    bool ok = false;
    try {
      ok = cv::imwrite(job->path.string(), job->image,
                       {cv::IMWRITE_PNG_COMPRESSION, options_.png_compression});
    } catch (const cv::Exception&) {
      ok = false;
    }
    std::error_code ec;
    const auto size = ok ? fs::file_size(job->path, ec) : 0;
    std::lock_guard lock(mutex_);
    if (!ok && error_.empty()) error_ = "cannot write " + job->path.string();
    stats_.bytes += size;
    if (ok && job->path.parent_path().filename() == "depth") ++stats_.written;
  }
}

void Recorder::add(const RgbdFrame& frame) {
  {
    std::lock_guard lock(mutex_);
    if (!error_.empty()) throw Error(error_ + " (disk full?)", {.file = dir_.string()});
    ++stats_.frames;
  }
  const std::string name = stamp(frame.timestamp) + ".png";
  // Colour first so that a sequence cut short never lists a depth image without its colour.
  jobs_.push({dir_ / "rgb" / name, frame.color});
  jobs_.push({dir_ / "depth" / name, frame.depth_raw});
  rgb_list_ << stamp(frame.timestamp) << " rgb/" << name << '\n' << std::flush;
  depth_list_ << stamp(frame.timestamp) << " depth/" << name << '\n' << std::flush;
}

void Recorder::add_imu(const dataset::ImuSample& s) {
  char buf[256];
  std::snprintf(buf, sizeof(buf), "%.6f %.9f %.9f %.9f %.9f %.9f %.9f\n", s.timestamp, s.gyro.x(),
                s.gyro.y(), s.gyro.z(), s.accel.x(), s.accel.y(), s.accel.z());
  imu_list_ << buf;
  std::lock_guard lock(mutex_);
  ++stats_.imu_samples;
}

RecorderStats Recorder::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

void Recorder::close() {
  if (closed_) return;
  closed_ = true;
  jobs_.close();
  for (std::thread& t : workers_)
    t.join();
  rgb_list_.close();
  depth_list_.close();
  imu_list_.close();
  write_settings_file(dir_ / "camera.yaml", camera_);
  for (const char* list : kLists) {
    std::error_code ec;
    fs::rename(dir_ / (std::string(list) + ".partial"), dir_ / list, ec);
    if (ec)
      throw Error("cannot rename into place: " + ec.message(), {.file = (dir_ / list).string()});
  }
  std::lock_guard lock(mutex_);
  if (!error_.empty()) throw Error(error_, {.file = dir_.string()});
}

}  // namespace coloc::capture
