// The IMU over iio, on a sysfs tree and a character device stood in by files with the bytes the
// kernel writes (hid-sensor-accel-3d / -gyro-3d scans).
#include <gtest/gtest.h>

#include <fstream>

#include "slam/capture/iio.hpp"
#include "slam/core/error.hpp"
#include "tests/slam/capture/test_support.hpp"
#include "tests/testing/data.hpp"

namespace coloc::capture {
namespace {

namespace fs = std::filesystem;

using testing::write_sysfs_file;

std::string read(const fs::path& p) {
  std::ifstream in(p);
  std::string s;
  std::getline(in, s);
  return s;
}

TEST(CaptureIio, ScanTypesAndLayout) {
  std::vector<IioChannel> ch = {parse_iio_type("in_timestamp", 3, "le:s64/64>>0"),
                                parse_iio_type("in_accel_x", 0, "le:s32/32>>0"),
                                parse_iio_type("in_accel_y", 1, "le:s32/32>>0"),
                                parse_iio_type("in_accel_z", 2, "be:s12/16>>4")};
  EXPECT_EQ(iio_layout(ch), 24u);  // 4 + 4 + 2, padded to 16 for the timestamp, + 8
  EXPECT_EQ(ch[2].offset, 8u);
  EXPECT_EQ(ch[3].offset, 16u);
  std::uint8_t scan[24] = {};
  scan[0] = 0xFE;  // x = -2 (le s32)
  scan[1] = scan[2] = scan[3] = 0xFF;
  scan[8] = 0xFF;  // z: big-endian 0xFFF0 >> 4 = 0xFFF = -1 in 12 bits
  scan[9] = 0xF0;
  EXPECT_EQ(iio_value(scan, ch[0]), -2);
  EXPECT_EQ(iio_value(scan, ch[2]), -1);
  EXPECT_THROW(parse_iio_type("in_accel_x", 0, "le:s33/32>>0"), Error);
  EXPECT_THROW(parse_iio_type("in_accel_x", 0, "s32"), Error);
}

// An iio device folder as hid-sensor-*-3d makes it, with `scans` as the character device.
IioSensor fake_sensor(const fs::path& root, const std::string& dir, const std::string& name,
                      const std::string& prefix, double scale,
                      const std::vector<std::array<std::int64_t, 4>>& scans) {
  const fs::path s = root / "sys" / dir;
  write_sysfs_file(s / "name", name);
  write_sysfs_file(s / (prefix + "_scale"), std::to_string(scale));
  write_sysfs_file(s / "buffer/enable", "0");
  write_sysfs_file(s / "buffer/length", "2");
  int i = 0;
  for (const std::string axis : {"_x", "_y", "_z"}) {
    write_sysfs_file(s / "scan_elements" / (prefix + axis + "_en"), "0");
    write_sysfs_file(s / "scan_elements" / (prefix + axis + "_index"), std::to_string(i++));
    write_sysfs_file(s / "scan_elements" / (prefix + axis + "_type"), "le:s32/32>>0");
  }
  write_sysfs_file(s / "scan_elements/in_timestamp_en", "0");
  write_sysfs_file(s / "scan_elements/in_timestamp_index", "3");
  write_sysfs_file(s / "scan_elements/in_timestamp_type", "le:s64/64>>0");
  const fs::path dev = root / "dev" / dir;
  fs::create_directories(dev.parent_path());
  std::ofstream out(dev, std::ios::binary);
  for (const auto& v : scans) {
    for (int k = 0; k < 3; ++k) {
      const auto x = static_cast<std::int32_t>(v[static_cast<std::size_t>(k)]);
      out.write(reinterpret_cast<const char*>(&x), 4);
    }
    out.write("\0\0\0\0", 4);  // padding before the 8-byte timestamp
    out.write(reinterpret_cast<const char*>(&v[3]), 8);
  }
  return {s, dev, name};
}

TEST(CaptureIio, BufferedSamplesAreScaledAndCombined) {
  const fs::path root = coloc::testing::temp_dir("capture_iio");
  // Accelerometer at 100 Hz (gravity on -y), gyroscope at 200 Hz turning about z.
  std::vector<std::array<std::int64_t, 4>> accel, gyro;
  for (int i = 0; i < 5; ++i)
    accel.push_back({0, -1000 - 10 * i, 0, 1'000'000'000 + 10'000'000LL * i});
  for (int i = 0; i < 9; ++i)
    gyro.push_back({0, 0, 500, 1'000'000'000 + 5'000'000LL * i});
  const IioSensor a = fake_sensor(root, "iio:device0", "accel_3d", "in_accel", 0.0098, accel);
  const IioSensor g = fake_sensor(root, "iio:device1", "gyro_3d", "in_anglvel", 0.001, gyro);
  const auto found = find_iio_imu(root / "sys", "");
  ASSERT_EQ(found.size(), 2u);
  EXPECT_EQ(found[0].name, "accel_3d");
  std::vector<dataset::ImuSample> samples;
  {
    ImuStream imu(a, g);
    // The files end: the stream's readers reach their ends and the thread finishes. The
    // deadline only stops a stuck run (CI runs the suite on a busy 2-core machine).
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (samples.size() < 9 && std::chrono::steady_clock::now() < deadline) {
      auto more = imu.take();
      samples.insert(samples.end(), more.begin(), more.end());
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    EXPECT_EQ(read(a.sysfs / "scan_elements/in_accel_x_en"), "1");
    EXPECT_EQ(read(g.sysfs / "buffer/enable"), "1");
  }
  EXPECT_EQ(read(g.sysfs / "buffer/enable"), "0");  // switched off when done
  ASSERT_EQ(samples.size(), 9u);
  EXPECT_NEAR(samples[0].timestamp, 1.0, 1e-12);
  EXPECT_NEAR(samples[0].gyro.z(), 0.5, 1e-12);
  EXPECT_NEAR(samples[0].accel.y(), -9.8, 1e-9);
  // Gyro sample 3 (t = 1.015) falls halfway between accelerometer samples 1 and 2.
  EXPECT_NEAR(samples[3].accel.y(), -0.0098 * 1015, 1e-9);
}

TEST(CaptureIio, UnwritableSysfsNamesTheFile) {
  const fs::path root = coloc::testing::temp_dir("capture_iio_perm");
  IioSensor a = fake_sensor(root, "iio:device0", "accel_3d", "in_accel", 0.01, {});
  fs::remove_all(a.sysfs / "buffer");
  try {
    IioReader r(a);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(e.context().file.find("buffer/enable"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace coloc::capture
