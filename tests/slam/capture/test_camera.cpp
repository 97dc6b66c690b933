// The capture path end to end on the replay device: streaming, metadata timestamps, drop
// accounting, registration, an unplugged camera, and the recorder writing a TUM sequence.
#include <gtest/gtest.h>

#include <chrono>
#include <opencv2/core.hpp>
#include <thread>

#include "slam/capture/camera.hpp"
#include "slam/capture/recorder.hpp"
#include "slam/capture/replay_build.hpp"
#include "tests/slam/capture/test_support.hpp"
#include "tests/testing/data.hpp"

namespace coloc::capture {
namespace {

namespace fs = std::filesystem;

CameraOptions vga_options() {
  CameraOptions o;
  o.depth = {kFourccZ16, 640, 480, 30};
  o.color = {kFourccYuyv, 640, 480, 30};
  return o;
}

std::vector<RgbdFrame> drain(RgbdCamera& camera) {
  std::vector<RgbdFrame> frames;
  while (auto f = camera.next())
    frames.push_back(std::move(*f));
  return frames;
}

TEST(CaptureCamera, ReplayedFramesComeBackRegisteredWithSensorTimestamps) {
  const testing::MemorySequence seq(6);
  auto system = replay_system(replay_from_sequence(seq, testing::test_camera(), {}));
  RgbdCamera camera(*system, vga_options());
  EXPECT_EQ(camera.device().model, "D455");
  EXPECT_NEAR(camera.color_camera().fx, 600.0, 1e-3);
  const auto frames = drain(camera);
  ASSERT_EQ(frames.size(), 6u);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    EXPECT_TRUE(frames[i].sensor_clock);
    const dataset::Frame truth = seq.frame(i);
    // Depth in millimetres, registered onto itself: equal within the mm rounding.
    cv::Mat depth_m;
    frames[i].depth_raw.convertTo(depth_m, CV_32F, 1e-3);
    EXPECT_LT(cv::norm(depth_m, truth.depth, cv::NORM_INF), 0.0011);
    EXPECT_LT(cv::norm(frames[i].color, truth.color, cv::NORM_L1) / truth.color.total(), 12.0);
  }
  // Sensor timestamps (not the kernel's, which carry 3 and 5 ms of transfer latency): frame i
  // is i/30 s after the first.
  EXPECT_NEAR(frames[5].timestamp - frames[0].timestamp, 5.0 / 30.0, 1e-6);
  EXPECT_DOUBLE_EQ(frames[3].timestamp, frames[3].depth_timestamp);
  const CaptureStats s = camera.stats();
  EXPECT_EQ(s.pairing.pairs, 6u);
  EXPECT_EQ(s.metadata_missing, 0u);
  EXPECT_FALSE(camera.unplugged());
  EXPECT_NE(camera.end_reason()->find("end of the replay"), std::string::npos);
}

// A replay served on demand has no clock: its streams wait for the reader, so a queue of one
// frame loses nothing and every frame has its metadata, whatever the machine's load.
TEST(CaptureCamera, UnpacedReplayWaitsForTheReaderAndLosesNothing) {
  const testing::MemorySequence seq(20);
  auto system = replay_system(replay_from_sequence(seq, testing::test_camera(), {}));
  CameraOptions o = vga_options();
  o.queue_capacity = 1;
  RgbdCamera camera(*system, o);
  EXPECT_EQ(drain(camera).size(), 20u);
  const CaptureStats s = camera.stats();
  EXPECT_EQ(s.depth.queue_drops + s.color.queue_drops, 0u);
  EXPECT_EQ(s.pairing.pairs, 20u);
  EXPECT_EQ(s.metadata_missing, 0u);
}

// Stopping a stream whose capture thread waits for room in the queue ends it (no hang).
TEST(CaptureCamera, StopEndsAnUnpacedReplayNobodyReads) {
  const testing::MemorySequence seq(20);
  auto system = replay_system(replay_from_sequence(seq, testing::test_camera(), {}));
  CameraOptions o = vga_options();
  o.queue_capacity = 1;
  RgbdCamera camera(*system, o);
  camera.stop();
  EXPECT_LE(drain(camera).size(), 1u);
}

TEST(CaptureCamera, KernelDropsAndQueueDropsAreCounted) {
  const testing::MemorySequence seq(12);
  // Paced like a camera: a replay served on demand waits for its reader and never drops.
  ReplayBuildOptions build{.kernel_drops = {3, 4, 9}, .metadata = false, .realtime = true};
  auto system = replay_system(replay_from_sequence(seq, testing::test_camera(), build));
  CameraOptions o = vga_options();
  o.queue_capacity = 2;
  RgbdCamera camera(*system, o);
  // Let the capture threads run through the 9 delivered frames before reading any: the queues
  // hold 2 per stream, the rest is dropped and counted. The deadline only stops a stuck run.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < deadline) {
    const CaptureStats s = camera.stats();
    if (s.depth.frames + s.depth.queue_drops == 9 && s.color.frames + s.color.queue_drops == 9)
      break;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  const auto frames = drain(camera);
  const CaptureStats s = camera.stats();
  EXPECT_EQ(s.depth.kernel_drops, 3u);  // sequence gaps 2->5 and 8->10
  EXPECT_EQ(s.color.kernel_drops, 3u);
  EXPECT_EQ(s.depth.queue_drops, 7u);
  EXPECT_EQ(s.color.queue_drops, 7u);
  EXPECT_EQ(frames.size(), 2u);
  EXPECT_FALSE(frames[0].sensor_clock);  // no metadata nodes: kernel timestamps
}

TEST(CaptureCamera, UnpluggedMidStreamKeepsTheRecordingSoFar) {
  const testing::MemorySequence seq(10);
  auto system =
      replay_system(replay_from_sequence(seq, testing::test_camera(), {.unplug_after = 5}));
  const fs::path out = coloc::testing::temp_dir("capture_unplug") / "rec";
  RgbdCamera camera(*system, vga_options());
  {
    Recorder recorder(out, {.camera = camera.color_camera(), .depth_map_factor = 1000.0});
    while (auto f = camera.next())
      recorder.add(*f);
    EXPECT_TRUE(camera.unplugged());
    EXPECT_NE(camera.end_reason()->find("unplugged"), std::string::npos);
    recorder.close();
    EXPECT_EQ(recorder.stats().written, 5u);
  }
  EXPECT_FALSE(fs::exists(out / "rgb.txt.partial"));
  const auto recorded = dataset::open_tum(out, {.depth_scale = 1000.0});
  ASSERT_EQ(recorded->size(), 5u);
  const dataset::Frame f = recorded->frame(4);
  EXPECT_LT(cv::norm(f.depth, seq.frame(4).depth, cv::NORM_INF), 0.0011);
  cv::FileStorage yaml((out / "camera.yaml").string(), cv::FileStorage::READ);
  EXPECT_DOUBLE_EQ(static_cast<double>(yaml["Camera1.fx"]), 600.0);
  EXPECT_DOUBLE_EQ(static_cast<double>(yaml["RGBD.DepthMapFactor"]), 1000.0);
  // A second recording into the same folder is refused before anything is written.
  EXPECT_THROW(Recorder(out, {.camera = camera.color_camera()}), Error);
}

}  // namespace
}  // namespace coloc::capture
