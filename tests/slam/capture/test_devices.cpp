// Discovery (a sysfs tree laid out as the kernel's), the replay device and the failures a user
// meets when opening a camera.
#include <gtest/gtest.h>

#include <fstream>

#include "slam/capture/camera.hpp"
#include "slam/capture/discovery.hpp"
#include "slam/capture/replay.hpp"
#include "slam/capture/replay_build.hpp"
#include "slam/core/yaml_text.hpp"
#include "tests/slam/capture/test_support.hpp"
#include "tests/testing/data.hpp"

namespace coloc::capture {
namespace {

namespace fs = std::filesystem;

using testing::write_sysfs_file;

TEST(CaptureDiscovery, SysfsNodesAreGroupedByUsbDevice) {
  const fs::path root = coloc::testing::temp_dir("capture_sysfs");
  // /sys/devices/.../2-1 (the D455) with interfaces 2-1:1.0 (depth) and 2-1:1.3 (RGB), and a
  // webcam on 1-4; /sys/class/video4linux/videoN/device links to the interfaces.
  const fs::path d455 = root / "devices/usb2/2-1";
  write_sysfs_file(d455 / "idVendor", "8086");
  write_sysfs_file(d455 / "idProduct", "0b5c");
  write_sysfs_file(d455 / "serial", "123456789012");
  write_sysfs_file(d455 / "speed", "5000");
  const fs::path webcam = root / "devices/usb1/1-4";
  write_sysfs_file(webcam / "idVendor", "046d");
  write_sysfs_file(webcam / "idProduct", "0825");
  write_sysfs_file(webcam / "speed", "480");
  const std::vector<std::tuple<int, fs::path, int, std::string>> nodes = {
      {0, d455 / "2-1:1.0", 0, "Intel(R) RealSense(TM) Depth Camera 455  Depth"},
      {1, d455 / "2-1:1.0", 1, "Intel(R) RealSense(TM) Depth Camera 455  Depth"},
      {4, d455 / "2-1:1.3", 0, "Intel(R) RealSense(TM) Depth Camera 455  RGB"},
      {10, webcam / "1-4:1.0", 0, "UVC Camera (046d:0825)"}};
  for (const auto& [n, iface, index, name] : nodes) {
    fs::create_directories(iface);
    const fs::path entry = root / "class/video4linux" / ("video" + std::to_string(n));
    write_sysfs_file(entry / "name", name);
    write_sysfs_file(entry / "index", std::to_string(index));
    fs::create_directory_symlink(iface, entry / "device");
  }
  const auto found = scan_sysfs(root / "class/video4linux");
  ASSERT_EQ(found.size(), 4u);
  EXPECT_EQ(found[0].device, "/dev/video0");
  EXPECT_EQ(found[3].device, "/dev/video10");  // numeric order, not text order
  EXPECT_EQ(found[0].vendor, 0x8086);
  EXPECT_EQ(found[0].product, 0x0b5c);
  EXPECT_EQ(found[0].serial, "123456789012");
  EXPECT_EQ(found[1].index, 1);
  EXPECT_EQ(found[0].usb_path, found[2].usb_path);
  EXPECT_NE(found[0].usb_path, found[3].usb_path);
  EXPECT_EQ(found[3].vendor, 0x046d);
}

TEST(CaptureDiscovery, NodesToldApartByTheirFormats) {
  auto system = replay_system(d455_description(nominal_d455_calibration()));
  const Discovery d = discover(*system);
  ASSERT_EQ(d.devices.size(), 1u);
  const RealSenseDevice& dev = d.devices[0];
  EXPECT_EQ(dev.model, "D455");
  EXPECT_TRUE(dev.usb3());
  ASSERT_EQ(dev.nodes.size(), 5u);
  EXPECT_EQ(dev.nodes[0].kind, StreamKind::kDepth);
  EXPECT_EQ(dev.nodes[1].kind, StreamKind::kMetadata);
  EXPECT_EQ(dev.nodes[2].kind, StreamKind::kInfrared);
  EXPECT_EQ(dev.nodes[3].kind, StreamKind::kColor);
  EXPECT_EQ(dev.metadata_of(dev.nodes[3])->info.device, "/dev/video5");
  EXPECT_EQ(dev.metadata_of(dev.nodes[2]), nullptr);
  EXPECT_EQ(d4xx_model(0x0b07), "D435");
  EXPECT_EQ(d4xx_model(0x0b3a), "D435i");
  EXPECT_EQ(d4xx_model(0x0ad3), "D415");
}

TEST(CaptureDiscovery, NoCameraSaysWhatToCheck) {
  ReplayDescription empty = d455_description(nominal_d455_calibration());
  for (ReplayNode& n : empty.nodes)
    n.info.vendor = 0x046d;  // only a webcam
  auto system = replay_system(empty);
  const Discovery d = discover(*system);
  EXPECT_TRUE(d.devices.empty());
  EXPECT_EQ(d.video_nodes, 5u);
  try {
    find_camera(*system, "auto");
    FAIL();
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("no RealSense camera found"), std::string::npos);
    EXPECT_NE(m.find("USB 3"), std::string::npos);
    EXPECT_NE(m.find("udev"), std::string::npos);
  }
}

// Opening the camera through the replay: the errno and what it means reach the user.
void expect_open_error(int error_number, const std::string& words) {
  ReplayDescription d = d455_description(nominal_d455_calibration());
  d.nodes[0].open_errno = error_number;
  auto system = replay_system(d);
  try {
    RgbdCamera camera(*system, CameraOptions{});
    FAIL() << "opened despite errno " << error_number;
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.error_number(), error_number);
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("/dev/video0"), std::string::npos) << e.what();
  }
}

TEST(CaptureDevice, BusyAndPermissionErrorsAreExplained) {
  expect_open_error(EBUSY, "another program holds it");
  expect_open_error(EACCES, "video");
}

TEST(CaptureDevice, UnsupportedModeIsRefused) {
  auto system = replay_system(d455_description(nominal_d455_calibration()));
  CameraOptions o;
  o.depth.fps = 45;  // the D455 offers 5/15/30/60/90
  try {
    RgbdCamera camera(*system, o);
    FAIL();
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.error_number(), EINVAL);
    EXPECT_NE(std::string(e.what()).find("Z16  848x480 at 45 fps"), std::string::npos) << e.what();
  }
  EXPECT_THROW(parse_mode("depth=848x480@30,colour=1x1@1", o), Error);
  parse_mode("depth=640x480@60,color=1280x720@30", o);
  EXPECT_EQ(o.depth.width, 640);
  EXPECT_EQ(o.depth.fps, 60.0);
  EXPECT_EQ(o.color.width, 1280);
}

TEST(CaptureDevice, UnreadableCalibrationNamesTheFallback) {
  ReplayDescription d = d455_description(nominal_d455_calibration());
  d.nodes[0].xu_errno = EIO;
  auto system = replay_system(d);
  try {
    RgbdCamera camera(*system, CameraOptions{});
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--calibration FILE"), std::string::npos) << e.what();
  }
  // A table the firmware does not know: the device's error code, and the same fallback.
  ReplayDescription unknown = d455_description(nominal_d455_calibration());
  unknown.nodes[0].tables.erase(kTableRgb);
  auto system2 = replay_system(unknown);
  try {
    RgbdCamera camera(*system2, CameraOptions{});
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("device code -1"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--calibration FILE"), std::string::npos);
  }
}

TEST(CaptureReplay, SavedDescriptionLoadsTheSame) {
  const testing::MemorySequence seq(3);
  const ReplayDescription d =
      replay_from_sequence(seq, testing::test_camera(), {.unplug_after = 2});
  const fs::path dir = coloc::testing::temp_dir("capture_replay_io");
  save_replay(d, dir);
  const ReplayDescription back = load_replay(dir);
  ASSERT_EQ(back.nodes.size(), d.nodes.size());
  EXPECT_EQ(back.nodes[0].frames.size(), 3u);
  EXPECT_EQ(back.nodes[0].frames[2].bytes, d.nodes[0].frames[2].bytes);
  EXPECT_EQ(back.nodes[0].frames[2].timestamp_ns, d.nodes[0].frames[2].timestamp_ns);
  EXPECT_EQ(back.nodes[0].unplug_after, 2u);
  EXPECT_EQ(back.nodes[0].tables, d.nodes[0].tables);
  EXPECT_EQ(back.nodes[3].formats[0].sizes[0].fps, d.nodes[3].formats[0].sizes[0].fps);
  EXPECT_THROW(load_replay(dir / "missing"), Error);
}

// An out-of-range or garbled frame timestamp names the frame (it said only "stoll"); a replay
// description OpenCV's reader would loop on is refused by the YAML guard.
TEST(CaptureReplay, BadDescriptionsNameTheField) {
  const testing::MemorySequence seq(2);
  const fs::path dir = coloc::testing::temp_dir("capture_replay_bad");
  save_replay(replay_from_sequence(seq, testing::test_camera(), {}), dir);
  const fs::path file = dir / "replay.yaml";
  const std::string text = read_yaml_text(file, "replay description");
  const std::size_t at = text.find("timestamp_ns");
  ASSERT_NE(at, std::string::npos);
  const std::size_t colon = text.find(':', at), end = text.find_first_of(",}\n", colon);
  for (const std::string bad : {"99999999999999999999999", "12x"}) {
    std::ofstream(file) << text.substr(0, colon + 1) << " \"" << bad << "\"" << text.substr(end);
    try {
      load_replay(dir);
      ADD_FAILURE() << bad << " accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.context().field, "frames[0].timestamp_ns") << e.what();
      EXPECT_EQ(e.context().file, file.string());
    }
  }
  std::ofstream(file) << text << "----x\n";
  EXPECT_THROW(load_replay(dir), Error);
}

}  // namespace
}  // namespace coloc::capture
