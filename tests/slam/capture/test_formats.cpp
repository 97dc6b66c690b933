// Decoding the bytes a D4xx sends: Z16, YUYV, UVC metadata, the factory calibration tables and
// the hardware-monitor framing; depth registration; pairing.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "slam/capture/calibration.hpp"
#include "slam/capture/formats.hpp"
#include "slam/capture/pairing.hpp"
#include "slam/capture/register.hpp"
#include "slam/core/error.hpp"

namespace coloc::capture {
namespace {

TEST(CaptureFormats, Z16DecodesLittleEndianWithStride) {
  // 3x2 pixels, a 8-byte stride (2 bytes of row padding), values 1..6 * 257.
  std::vector<std::uint8_t> bytes;
  for (int y = 0; y < 2; ++y) {
    for (int x = 0; x < 3; ++x) {
      const std::uint16_t v = static_cast<std::uint16_t>((y * 3 + x + 1) * 257 + x);
      bytes.push_back(static_cast<std::uint8_t>(v & 0xff));
      bytes.push_back(static_cast<std::uint8_t>(v >> 8));
    }
    bytes.push_back(0xee);
    bytes.push_back(0xee);
  }
  const cv::Mat d = decode_z16(bytes, 3, 2, 8);
  ASSERT_EQ(d.type(), CV_16UC1);
  EXPECT_EQ(d.at<std::uint16_t>(0, 0), 257);
  EXPECT_EQ(d.at<std::uint16_t>(1, 2), 6 * 257 + 2);
  EXPECT_THROW(decode_z16(std::span(bytes).first(10), 3, 2, 8), Error);
}

TEST(CaptureFormats, YuyvRoundTripKeepsColours) {
  cv::Mat bgr(8, 16, CV_8UC3, cv::Scalar(30, 120, 220));
  bgr(cv::Rect(8, 0, 8, 8)).setTo(cv::Scalar(200, 40, 60));
  const auto bytes = encode_yuyv(bgr);
  ASSERT_EQ(bytes.size(), 8u * 16u * 2u);
  const cv::Mat back = decode_color(bytes, kFourccYuyv, 16, 8);
  EXPECT_LT(cv::norm(back, bgr, cv::NORM_INF), 6.0);  // 8-bit YUV rounding only
  EXPECT_THROW(decode_color(bytes, kFourccZ16, 16, 8), Error);
  EXPECT_EQ(fourcc_name(kFourccZ16), "Z16 ");
  EXPECT_EQ(fourcc_name(0x01020304), "0x01020304");
}

TEST(CaptureFormats, UvcMetadataCarriesSensorTimestampAndCounter) {
  FrameMetadata m{.host_ns = 123456789012ULL,
                  .usb_sof = 77,
                  .pts = 4242,
                  .frame_counter = 99,
                  .sensor_timestamp_us = 0xFFFFFF00u,
                  .exposure_us = 8000};
  const auto bytes = encode_uvc_metadata(m);
  const FrameMetadata p = parse_uvc_metadata(bytes);
  EXPECT_EQ(p.host_ns, m.host_ns);
  EXPECT_EQ(p.usb_sof, 77);
  EXPECT_EQ(p.pts, 4242u);
  EXPECT_EQ(p.frame_counter, 99u);
  EXPECT_EQ(p.sensor_timestamp_us, 0xFFFFFF00u);
  EXPECT_EQ(p.exposure_us, 8000u);
  // A header length running past the buffer names its offset.
  auto bad = bytes;
  bad[10] = 200;
  try {
    parse_uvc_metadata(bad);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.context().offset, 10u);
  }
  // A plain UVC header without Intel blocks: no sensor timestamp, no error.
  auto plain = std::vector<std::uint8_t>(bytes.begin(), bytes.begin() + 12 + 12);
  plain[10] = 12;
  plain[12] = 12;
  EXPECT_FALSE(parse_uvc_metadata(plain).sensor_timestamp_us);
}

TEST(CaptureFormats, SensorClockUnwrapsThe32BitCounter) {
  SensorClock c;
  EXPECT_DOUBLE_EQ(c.seconds(0xFFFF0000u), 0.0);
  EXPECT_NEAR(c.seconds(0x00010000u), 0x20000 * 1e-6, 1e-12);             // across the wrap
  EXPECT_NEAR(c.seconds(0x0000F000u), (0x20000 - 0x1000) * 1e-6, 1e-12);  // a small step back
}

TEST(CaptureCalibration, TablesRoundTripWithChecksums) {
  const DepthColorCalibration c = nominal_d455_calibration();
  const auto coefficients = build_coefficients_table(c);
  const auto rgb = build_rgb_table(c);
  EXPECT_EQ(coefficients.size(), 576u);
  EXPECT_EQ(rgb.size(), 256u);
  const DepthColorCalibration p = parse_calibration(coefficients, rgb);
  EXPECT_NEAR(p.baseline_m, 0.095, 1e-6);
  const PinholeCamera d = p.depth_camera(848, 480);
  EXPECT_NEAR(d.fx, 428.0, 1e-3);
  EXPECT_NEAR(d.cx, 423.5, 1e-3);
  EXPECT_THROW(p.depth_camera(320, 180), Error);
  const PinholeCamera col = p.color_camera(1280, 800);
  EXPECT_NEAR(col.fx, 640.0, 1e-3);
  EXPECT_NEAR(col.cx, 640.5, 1e-3);
  EXPECT_NEAR(col.cy, 398.5, 1e-3);
  // 640x480 is 4:3, wider than the 16:10 calibration: fx and cx scale, fy stays.
  const PinholeCamera vga = p.color_camera(640, 480);
  EXPECT_NEAR(vga.fy, 640.0 / 400.0 * 240.0, 1e-3);
  EXPECT_NEAR(vga.fx, 320.0 * (480.0 / 640.0) / (800.0 / 1280.0), 1e-3);
  EXPECT_NEAR(p.color_distortion[0], -0.055, 1e-6);
  EXPECT_LT((p.color_from_depth.translation() - c.color_from_depth.translation()).norm(), 1e-6);
  EXPECT_LT((p.color_from_depth.rotation() - c.color_from_depth.rotation()).norm(), 1e-6);
}

TEST(CaptureCalibration, InverseColourDistortionBecomesForward) {
  // The tables' coefficients undistort; the camera handed to SLAM must distort (OpenCV's model).
  const DepthColorCalibration c = nominal_d455_calibration();
  const PinholeCamera cam = c.color_camera(1280, 800);
  const auto& k = c.color_distortion;
  for (const Eigen::Vector2d& xu :
       {Eigen::Vector2d(0.6, 0.4), Eigen::Vector2d(-0.8, 0.5), Eigen::Vector2d(0.1, -0.55)}) {
    const Eigen::Vector2d xd = cam.distort(xu);
    const double rd = xd.squaredNorm();
    const double f = 1.0 + rd * (k[0] + rd * (k[1] + rd * k[4]));
    const Eigen::Vector2d back(
        xd.x() * f + 2 * k[2] * xd.x() * xd.y() + k[3] * (rd + 2 * xd.x() * xd.x()),
        xd.y() * f + 2 * k[3] * xd.x() * xd.y() + k[2] * (rd + 2 * xd.y() * xd.y()));
    EXPECT_LT((back - xu).norm() * cam.fx, 0.05) << xu.transpose();  // pixels
  }
  EXPECT_NEAR(cam.distortion[0], 0.055, 0.01);  // about the negated inverse coefficient
}

TEST(CaptureCalibration, DamagedOrUnknownTablesNameTheFallback) {
  const DepthColorCalibration c = nominal_d455_calibration();
  auto coefficients = build_coefficients_table(c);
  const auto rgb = build_rgb_table(c);
  coefficients[300] ^= 0x40;  // one flipped bit in the rectified intrinsics
  try {
    parse_calibration(coefficients, rgb);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("CRC-32"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--calibration FILE"), std::string::npos);
  }
  const auto short_rgb = std::vector<std::uint8_t>(rgb.begin(), rgb.begin() + 100);
  EXPECT_THROW(parse_calibration(build_coefficients_table(c), short_rgb), Error);
  EXPECT_EQ(crc32(std::vector<std::uint8_t>{'1', '2', '3', '4', '5', '6', '7', '8', '9'}),
            0xCBF43926u);  // the CRC-32 check value
}

TEST(CaptureCalibration, HardwareMonitorFraming) {
  const auto cmd = hw_monitor_command(kOpGetIntCal, kTableRgb);
  ASSERT_EQ(cmd.size(), kHwMonitorBufferSize);
  EXPECT_EQ(cmd[0], 20);  // length after the prefix
  EXPECT_EQ(cmd[2], 0xAB);
  EXPECT_EQ(cmd[3], 0xCD);  // magic 0xCDAB, little-endian
  EXPECT_EQ(cmd[4], 0x15);
  EXPECT_EQ(cmd[8], kTableRgb);
  const std::vector<std::uint8_t> payload = {1, 2, 3, 4, 5};
  const auto answer = hw_monitor_answer(kOpGetIntCal, payload);
  EXPECT_EQ(hw_monitor_payload(answer, kOpGetIntCal), payload);
  EXPECT_THROW(hw_monitor_payload(answer, 0x10), Error);  // another command's echo
  auto impossible = answer;
  impossible[kHwMonitorBufferSize - 3] = 0x7f;
  EXPECT_THROW(hw_monitor_payload(impossible, kOpGetIntCal), Error);
}

TEST(CaptureRegistration, IdentityKeepsDepthAndBaselineShiftsIt) {
  const PinholeCamera cam{64, 48, 50.0, 50.0, 31.5, 23.5, {}};
  cv::Mat depth(48, 64, CV_16UC1, cv::Scalar(2000));  // a wall at 2 m
  depth.at<std::uint16_t>(10, 10) = 0;
  const DepthRegistrar same(cam, cam, SE3());
  const cv::Mat out = same.register_raw(depth, 1000.0);
  EXPECT_EQ(out.at<std::uint16_t>(20, 20), 2000);
  EXPECT_EQ(out.at<std::uint16_t>(10, 10), 0);
  // The colour camera 8 cm to the left sees the wall 2 px (50 * 0.08 / 2) further right.
  const DepthRegistrar shifted(cam, cam, SE3(SO3(), Eigen::Vector3d(0.08, 0.0, 0.0)));
  const cv::Mat moved = shifted.register_raw(depth, 1000.0);
  EXPECT_EQ(moved.at<std::uint16_t>(10, 12), 0);  // the hole moved with the wall
  EXPECT_EQ(moved.at<std::uint16_t>(10, 10), 2000);
  EXPECT_EQ(moved.at<std::uint16_t>(20, 0), 0);  // nothing projects to the first columns
  PinholeCamera distorted = cam;
  distorted.distortion[0] = 0.1;
  EXPECT_THROW(DepthRegistrar(distorted, cam, SE3()), Error);
}

TEST(CapturePairing, NearestDepthWithinToleranceAndCounts) {
  FramePairer<int> p(0.010);
  // Depth at 30 Hz from t = 0; colour at 30 Hz offset by 4 ms, one colour frame far off.
  for (int i = 0; i < 6; ++i)
    p.add_depth(i / 30.0, i);
  p.add_color(0.004, 100);
  p.add_color(1.0 / 30 + 0.004, 101);
  p.add_color(2.0 / 30 + 0.020, 102);  // 20 ms from every depth frame
  p.add_color(4.0 / 30 - 0.003, 104);
  std::vector<std::pair<int, int>> pairs;
  while (auto q = p.next())
    pairs.emplace_back(q->depth, q->color);
  ASSERT_EQ(pairs.size(), 3u);
  EXPECT_EQ(pairs[0], std::make_pair(0, 100));
  EXPECT_EQ(pairs[1], std::make_pair(1, 101));
  EXPECT_EQ(pairs[2], std::make_pair(4, 104));
  EXPECT_EQ(p.counters().unpaired_color, 1u);
  EXPECT_EQ(p.counters().unpaired_depth, 2u);  // depth 2 and 3 found no colour
}

}  // namespace
}  // namespace coloc::capture
