#pragma once
// The D4xx factory calibration: read from the camera's hardware monitor (a command sent and its
// answer read through the depth node's UVC extension unit) as binary tables, parsed here from
// their documented layout with the CRC-32 of every table checked.
//
// Hardware-monitor command (little-endian, sent as 1024 bytes to XU control 1 of unit 3): u16
// length (bytes after this field's 4-byte prefix), u16 magic 0xCDAB, u32 opcode, 4 x u32
// parameters, data. The answer (1024 bytes read back) is the u32 opcode echoed (or a negative
// error code), the payload, and in its last 4 bytes the payload's length. GETINTCAL (0x15) with
// parameter 1 = table id returns a table: a 16-byte header (u16 version, big-endian; u16 type;
// u32 size; u32 param; u32 CRC-32 of the bytes after the header) then the body.
// Table 25 (coefficients): left/right normalized intrinsics, rotations, baseline (mm), then
// per-resolution rectified intrinsics {fx, fy, ppx, ppy} of the depth (left) imager. Table 32
// (RGB): normalized colour intrinsics (K row-major, f and p over half the calibration
// width/height), Brown distortion, the depth-to-colour rectification rotation and translation.
#include <array>
#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

#include "slam/core/camera.hpp"
#include "slam/core/se3.hpp"

namespace coloc::capture {

constexpr std::uint8_t kDepthXuUnit = 3;
constexpr std::uint8_t kHwMonitorSelector = 1;
constexpr std::size_t kHwMonitorBufferSize = 1024;
constexpr std::uint32_t kOpGetIntCal = 0x15;
constexpr std::uint16_t kTableCoefficients = 25;
constexpr std::uint16_t kTableRgb = 32;

// Resolutions of the coefficients table's rectified-intrinsics array, in table order.
constexpr std::array<std::array<int, 2>, 13> kRectResolutions = {{{1920, 1080},
                                                                  {1280, 720},
                                                                  {640, 480},
                                                                  {848, 480},
                                                                  {640, 360},
                                                                  {424, 240},
                                                                  {320, 240},
                                                                  {480, 270},
                                                                  {1280, 800},
                                                                  {960, 540},
                                                                  {0, 0},
                                                                  {0, 0},
                                                                  {640, 400}}};

// The hardware-monitor command bytes for `opcode` and its parameters.
std::vector<std::uint8_t> hw_monitor_command(std::uint32_t opcode, std::uint32_t p1 = 0,
                                             std::uint32_t p2 = 0, std::uint32_t p3 = 0,
                                             std::uint32_t p4 = 0);
// The payload of a 1024-byte answer to `opcode`. Throws coloc::Error with the device's error
// code when the echo is not the opcode, or when the stated length is impossible.
std::vector<std::uint8_t> hw_monitor_payload(std::span<const std::uint8_t> answer,
                                             std::uint32_t opcode);
// The answer a camera gives (for replay devices and tests).
std::vector<std::uint8_t> hw_monitor_answer(std::uint32_t opcode,
                                            std::span<const std::uint8_t> payload);

// CRC-32 (IEEE 802.3, reflected, as zlib), the tables' checksum.
std::uint32_t crc32(std::span<const std::uint8_t> bytes);

struct DepthColorCalibration {
  double baseline_m = 0.0;  // stereo baseline
  // Rectified depth (left imager) intrinsics per streamed resolution, no distortion.
  std::vector<PinholeCamera> depth_modes;
  // Colour intrinsics at the calibration resolution, normalized as in the table.
  std::array<double, 4> color_normalized{};  // fx, fy, ppx, ppy over half width / height
  // k1 k2 p1 p2 k3. The factory tables' coefficients undistort (librealsense calls the model
  // inverse Brown-Conrady); color_camera() turns them into the forward (OpenCV, ORB-SLAM)
  // coefficients by a least-squares fit. A --calibration file's coefficients are forward.
  std::array<double, 5> color_distortion{};
  bool color_distortion_inverse = true;
  int color_calib_width = 0, color_calib_height = 0;
  SE3 color_from_depth;  // maps depth-camera points (metres) into the colour camera frame

  // Depth intrinsics at width x height; throws coloc::Error naming the resolution if absent.
  PinholeCamera depth_camera(int width, int height) const;
  // Colour intrinsics at width x height (aspect-ratio compensated as the firmware defines).
  PinholeCamera color_camera(int width, int height) const;
};

// Parses the two tables. Throws coloc::Error naming the table, the field and byte offset
// (unknown table type, short table, CRC mismatch).
DepthColorCalibration parse_calibration(std::span<const std::uint8_t> coefficients_table,
                                        std::span<const std::uint8_t> rgb_table);

// Builds both tables from a calibration (the inverse of parse_calibration): replay devices and
// tests use it to give the capture code the bytes a camera would.
std::vector<std::uint8_t> build_coefficients_table(const DepthColorCalibration& calibration);
std::vector<std::uint8_t> build_rgb_table(const DepthColorCalibration& calibration);

// Forward Brown-Conrady coefficients equivalent to inverse ones (which map distorted
// normalized coordinates to undistorted ones) over |x| <= half_x, |y| <= half_y.
std::array<double, 5> forward_from_inverse_brown(const std::array<double, 5>& inverse,
                                                 double half_x, double half_y);

// A D455-like calibration (nominal values, 95 mm baseline), for replay devices and tests.
DepthColorCalibration nominal_d455_calibration();

// `--calibration FILE` (the fallback when the camera's tables cannot be read): an ORB-SLAM3 /
// coloc camera YAML with the colour camera (Camera1.*), and optionally `Depth.fx fy cx cy`,
// `Depth.width height` and a 4x4 `color_from_depth` matrix (identity when absent, i.e. depth
// already registered). Throws coloc::Error naming the file and key.
DepthColorCalibration load_calibration_file(const std::filesystem::path& path, int depth_width,
                                            int depth_height);

}  // namespace coloc::capture
