#pragma once
// The D4xx IMU through the kernel's industrial-I/O subsystem: the camera's HID accelerometer
// and gyroscope appear as iio devices named accel_3d and gyro_3d (hid-sensor-accel-3d,
// hid-sensor-gyro-3d) under /sys/bus/iio/devices, below the camera's USB device. Buffered
// capture: the x/y/z and timestamp scan elements are enabled, the buffer is switched on, and
// samples are read from the character device /dev/iio:deviceN as packed scans whose layout the
// scan_elements/*_type files give ("le:s32/32>>0": endianness, sign, bits/storage, shift).
// Timestamps are the host's CLOCK_MONOTONIC (current_timestamp_clock), the V4L2 clock; upstream
// kernels do not expose the camera's own IMU timestamps.
#include <atomic>
#include <filesystem>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "slam/core/bounded_queue.hpp"
#include "slam/dataset/sequence.hpp"

namespace coloc::capture {

struct IioChannel {
  std::string name;  // "in_accel_x", "in_timestamp"
  int index = 0;     // scan order
  bool is_signed = true, big_endian = false;
  int bits = 0, storage_bits = 0, shift = 0;
  std::size_t offset = 0;  // byte offset in a scan (iio_layout)
};

// Parses a scan_elements *_type text. Throws coloc::Error naming `name` when malformed.
IioChannel parse_iio_type(const std::string& name, int index, const std::string& type);
// Byte offsets of `channels` (sorted by index, each aligned to its storage size); returns the
// scan size (padded to the largest alignment).
std::size_t iio_layout(std::vector<IioChannel>& channels);
// One channel's value from a scan.
std::int64_t iio_value(const std::uint8_t* scan, const IioChannel& channel);

struct IioSensor {
  std::filesystem::path sysfs;   // /sys/bus/iio/devices/iio:deviceN
  std::filesystem::path device;  // /dev/iio:deviceN
  std::string name;              // accel_3d / gyro_3d
};

// The accel_3d and gyro_3d devices below `usb_path` (any USB device when empty).
std::vector<IioSensor> find_iio_imu(const std::filesystem::path& iio_root,
                                    const std::string& usb_path);

struct IioSample {
  double timestamp = 0.0;                           // seconds, host monotonic clock
  Eigen::Vector3d value = Eigen::Vector3d::Zero();  // scaled: m/s^2 or rad/s
};

// One buffered iio sensor: enables its channels and buffer through sysfs, reads scans from the
// character device. Not thread-safe; the IMU stream runs one reader per thread.
class IioReader {
 public:
  // Throws coloc::Error naming the sysfs file that cannot be written (permissions: udev rules).
  explicit IioReader(const IioSensor& sensor, int buffer_length = 128);
  ~IioReader();  // disables the buffer
  IioReader(const IioReader&) = delete;
  IioReader& operator=(const IioReader&) = delete;

  // Waits up to timeout_ms; the samples of the scans read (empty on timeout or at end of file).
  std::vector<IioSample> read(int timeout_ms);
  bool at_end() const { return at_end_; }

 private:
  IioSensor sensor_;
  std::string prefix_;  // "in_accel" / "in_anglvel"
  std::vector<IioChannel> channels_;
  std::size_t scan_bytes_ = 0;
  double scale_ = 1.0;
  int fd_ = -1;
  bool at_end_ = false;
  std::vector<std::uint8_t> pending_;
};

// Gyroscope and accelerometer combined into IMU samples at the gyroscope's times (the
// accelerometer, slower on D4xx, linearly interpolated), on a thread; pop() hands them on.
class ImuStream {
 public:
  ImuStream(const IioSensor& accel, const IioSensor& gyro);
  ~ImuStream();
  ImuStream(const ImuStream&) = delete;
  ImuStream& operator=(const ImuStream&) = delete;
  // Samples ready now (never blocks).
  std::vector<dataset::ImuSample> take();
  void stop();
  std::size_t dropped() const { return dropped_; }  // samples lost because take() lagged

 private:
  void run();
  IioReader accel_, gyro_;
  std::atomic<bool> stop_{false};
  std::atomic<std::size_t> dropped_{0};
  BoundedQueue<dataset::ImuSample> queue_;
  std::thread thread_;
};

}  // namespace coloc::capture
