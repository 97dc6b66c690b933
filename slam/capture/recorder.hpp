#pragma once
// Writes a live RGB-D (+IMU) stream as a TUM RGB-D sequence that `coloc map` reads: rgb/*.png,
// depth/*.png (16-bit, depth units), rgb.txt, depth.txt, imu.txt and camera.yaml (ORB-SLAM3
// v1.0, the colour camera: depth is registered to it). PNG encoding runs on worker threads
// behind a bounded queue, as the twin generator does; the lists are written as `<name>.partial`
// while recording and renamed by close(), which also runs from the destructor, so a camera
// unplugged mid-stream or Ctrl-C still leaves a complete, readable sequence of what came.
// add()/add_imu()/close() from one thread.
#include <filesystem>
#include <fstream>
#include <mutex>
#include <thread>

#include "slam/capture/camera.hpp"
#include "slam/capture/settings_file.hpp"
#include "slam/core/bounded_queue.hpp"
#include "slam/dataset/sequence.hpp"

namespace coloc::capture {

struct RecorderOptions {
  unsigned png_workers = 2;
  std::size_t queue_capacity = 16;  // frames waiting for the PNG workers (add() blocks beyond)
  int png_compression = 1;          // zlib level: fast, as the twin writes
  void check() const;               // throws coloc::Error naming the field
};

struct RecorderStats {
  std::size_t frames = 0;   // pairs queued
  std::size_t written = 0;  // pairs whose both PNGs are on disk
  std::size_t imu_samples = 0;
  std::uint64_t bytes = 0;  // PNG bytes written
};

class Recorder {
 public:
  // Creates DIR/rgb and DIR/depth; refuses a DIR that already holds a sequence (rgb.txt).
  Recorder(std::filesystem::path dir, SettingsFileContent camera, RecorderOptions options = {});
  ~Recorder();
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  void add(const RgbdFrame& frame);
  void add_imu(const dataset::ImuSample& sample);
  RecorderStats stats() const;
  // Waits for the workers, writes camera.yaml and renames the lists into place. Throws
  // coloc::Error on a failed write. Idempotent.
  void close();

 private:
  struct Job {
    std::filesystem::path path;
    cv::Mat image;
  };
  void work();

  std::filesystem::path dir_;
  SettingsFileContent camera_;
  RecorderOptions options_;
  std::ofstream rgb_list_, depth_list_, imu_list_;
  BoundedQueue<Job> jobs_;
  std::vector<std::thread> workers_;
  mutable std::mutex mutex_;  // guards stats_ and error_
  RecorderStats stats_;
  std::string error_;
  bool closed_ = false;
};

}  // namespace coloc::capture
