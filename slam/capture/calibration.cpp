#include "slam/capture/calibration.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/core.hpp>

#include "slam/capture/bytes.hpp"
#include "slam/core/error.hpp"
#include "slam/core/rigid.hpp"
#include "slam/core/yaml_text.hpp"
#include "slam/settings/opencv_matrix.hpp"

namespace coloc::capture {
namespace {

using detail::read_le;
using detail::write_le;

constexpr std::uint16_t kMagic = 0xCDAB;
constexpr std::size_t kHeaderBytes = 16;
constexpr std::size_t kCoefficientsBytes = 576;
constexpr std::size_t kRgbBytes = 256;
// Offsets in the coefficients table.
constexpr std::size_t kBaselineAt = 160;
constexpr std::size_t kRectParamsAt = 256;
// Offsets in the RGB table.
constexpr std::size_t kRgbIntrinsicAt = 16;
constexpr std::size_t kRgbDistortionAt = 52;
constexpr std::size_t kRgbCalibSizeAt = 144;
constexpr std::size_t kRgbRotationRectAt = 184;
constexpr std::size_t kRgbTranslationRectAt = 220;

std::string hex(std::uint32_t v) {
  char buf[16];
  std::snprintf(buf, sizeof(buf), "0x%08x", v);
  return buf;
}

// Header checks shared by both tables; errors name the table and say what to do instead.
void check_table(std::span<const std::uint8_t> table, std::size_t layout_bytes, const char* name) {
  const std::string what = std::string("calibration table ") + name;
  const std::string fallback = " (pass the camera's calibration with --calibration FILE)";
  if (table.size() < layout_bytes)
    throw Error(what + " has " + std::to_string(table.size()) + " bytes, the known layout " +
                    std::to_string(layout_bytes) + ": unknown table version " +
                    hex(table.size() >= 2 ? (table[0] << 8) | table[1] : 0) + fallback,
                {.field = name, .offset = table.size()});
  const auto stored = read_le<std::uint32_t>(table, 12, what);
  const std::uint32_t computed = crc32(table.subspan(kHeaderBytes));
  if (stored != computed)
    throw Error(what + ": CRC-32 " + hex(computed) + " does not match the stored " + hex(stored) +
                    " (damaged read)" + fallback,
                {.field = name, .offset = 12});
}

float f32(std::span<const std::uint8_t> t, std::size_t at) {
  return read_le<float>(t, at, "float");
}

std::vector<std::uint8_t> with_header(std::vector<std::uint8_t> table, std::uint16_t type) {
  write_le<std::uint16_t>(table, 0, 0x0002);  // version 2.0, stored big-endian
  write_le<std::uint16_t>(table, 2, type);
  write_le<std::uint32_t>(table, 4, static_cast<std::uint32_t>(table.size() - kHeaderBytes));
  write_le<std::uint32_t>(table, 8, 0);
  write_le<std::uint32_t>(table, 12, crc32(std::span(table).subspan(kHeaderBytes)));
  return table;
}

}  // namespace

std::vector<std::uint8_t> hw_monitor_command(std::uint32_t opcode, std::uint32_t p1,
                                             std::uint32_t p2, std::uint32_t p3, std::uint32_t p4) {
  std::vector<std::uint8_t> cmd(kHwMonitorBufferSize, 0);
  write_le<std::uint16_t>(cmd, 0, 20);  // bytes after the 4-byte prefix: opcode + 4 params
  write_le<std::uint16_t>(cmd, 2, kMagic);
  write_le<std::uint32_t>(cmd, 4, opcode);
  write_le<std::uint32_t>(cmd, 8, p1);
  write_le<std::uint32_t>(cmd, 12, p2);
  write_le<std::uint32_t>(cmd, 16, p3);
  write_le<std::uint32_t>(cmd, 20, p4);
  return cmd;
}

std::vector<std::uint8_t> hw_monitor_payload(std::span<const std::uint8_t> answer,
                                             std::uint32_t opcode) {
  if (answer.size() < kHwMonitorBufferSize)
    throw Error("hardware monitor: short answer of " + std::to_string(answer.size()) + " bytes");
  const auto echo = read_le<std::uint32_t>(answer, 0, "hardware monitor echo");
  if (echo != opcode)
    throw Error("hardware monitor: command " + hex(opcode) + " failed with device code " +
                std::to_string(static_cast<std::int32_t>(echo)));
  const auto length = read_le<std::uint32_t>(answer, kHwMonitorBufferSize - 4, "length");
  if (length > kHwMonitorBufferSize - 8)
    throw Error("hardware monitor: answer length " + std::to_string(length) + " is impossible",
                {.offset = kHwMonitorBufferSize - 4});
  return {answer.begin() + 4, answer.begin() + 4 + length};
}

std::vector<std::uint8_t> hw_monitor_answer(std::uint32_t opcode,
                                            std::span<const std::uint8_t> payload) {
  if (payload.size() > kHwMonitorBufferSize - 8)
    throw Error("hardware monitor: payload of " + std::to_string(payload.size()) +
                " bytes does not fit one answer");
  std::vector<std::uint8_t> out(kHwMonitorBufferSize, 0);
  write_le<std::uint32_t>(out, 0, opcode);
  std::copy(payload.begin(), payload.end(), out.begin() + 4);
  write_le<std::uint32_t>(out, kHwMonitorBufferSize - 4,
                          static_cast<std::uint32_t>(payload.size()));
  return out;
}

std::uint32_t crc32(std::span<const std::uint8_t> bytes) {
  std::uint32_t crc = 0xFFFFFFFFu;
  for (std::uint8_t b : bytes) {
    crc ^= b;
    for (int k = 0; k < 8; ++k)
      crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

PinholeCamera DepthColorCalibration::depth_camera(int width, int height) const {
  for (const PinholeCamera& c : depth_modes)
    if (c.width == width && c.height == height) return c;
  throw Error("the depth calibration has no intrinsics for " + std::to_string(width) + "x" +
              std::to_string(height));
}

PinholeCamera DepthColorCalibration::color_camera(int width, int height) const {
  double nfx = color_normalized[0], nfy = color_normalized[1];
  double npx = color_normalized[2], npy = color_normalized[3];
  // The firmware normalizes at one aspect ratio; other ratios are cropped from it.
  const double calib_ratio = color_calib_width > 0
                                 ? static_cast<double>(color_calib_height) / color_calib_width
                                 : 9.0 / 16.0;
  const double ratio = static_cast<double>(height) / width;
  if (ratio < calib_ratio) {
    nfy *= calib_ratio / ratio;
    npy *= calib_ratio / ratio;
  } else {
    nfx *= ratio / calib_ratio;
    npx *= ratio / calib_ratio;
  }
  PinholeCamera c;
  c.width = width;
  c.height = height;
  c.fx = nfx * width / 2.0;
  c.fy = nfy * height / 2.0;
  c.cx = (1.0 + npx) * width / 2.0;
  c.cy = (1.0 + npy) * height / 2.0;
  c.distortion = color_distortion_inverse
                     ? forward_from_inverse_brown(color_distortion, 1.0 / nfx, 1.0 / nfy)
                     : color_distortion;
  return c;
}

std::array<double, 5> forward_from_inverse_brown(const std::array<double, 5>& k, double half_x,
                                                 double half_y) {
  if (std::all_of(k.begin(), k.end(), [](double v) { return v == 0.0; })) return k;
  // Forward distortion is linear in its coefficients once the undistorted point is known: each
  // distorted grid point gives two equations xd - xu = A(xu, yu) * [k1 k2 k3 p1 p2].
  constexpr int kSteps = 21;
  Eigen::MatrixXd a(2 * kSteps * kSteps, 5);
  Eigen::VectorXd b(2 * kSteps * kSteps);
  int row = 0;
  for (int i = 0; i < kSteps; ++i) {
    for (int j = 0; j < kSteps; ++j) {
      const double xd = half_x * (2.0 * i / (kSteps - 1) - 1.0);
      const double yd = half_y * (2.0 * j / (kSteps - 1) - 1.0);
      const double rd = xd * xd + yd * yd;
      const double f = 1.0 + rd * (k[0] + rd * (k[1] + rd * k[4]));
      const double xu = xd * f + 2.0 * k[2] * xd * yd + k[3] * (rd + 2.0 * xd * xd);
      const double yu = yd * f + 2.0 * k[3] * xd * yd + k[2] * (rd + 2.0 * yd * yd);
      const double r2 = xu * xu + yu * yu;
      a.row(row) << xu * r2, xu * r2 * r2, xu * r2 * r2 * r2, 2.0 * xu * yu, r2 + 2.0 * xu * xu;
      b(row++) = xd - xu;
      a.row(row) << yu * r2, yu * r2 * r2, yu * r2 * r2 * r2, r2 + 2.0 * yu * yu, 2.0 * xu * yu;
      b(row++) = yd - yu;
    }
  }
  const Eigen::VectorXd x = a.colPivHouseholderQr().solve(b);
  return {x(0), x(1), x(3), x(4), x(2)};
}

DepthColorCalibration parse_calibration(std::span<const std::uint8_t> coefficients,
                                        std::span<const std::uint8_t> rgb) {
  check_table(coefficients, kCoefficientsBytes, "25 (depth coefficients)");
  check_table(rgb, kRgbBytes, "32 (RGB)");
  DepthColorCalibration c;
  c.baseline_m = std::abs(f32(coefficients, kBaselineAt)) * 1e-3;
  for (std::size_t i = 0; i < kRectResolutions.size(); ++i) {
    const auto [w, h] = kRectResolutions[i];
    const std::size_t at = kRectParamsAt + 16 * i;
    if (w == 0 || f32(coefficients, at) <= 0.0f) continue;
    PinholeCamera cam;
    cam.width = w;
    cam.height = h;
    cam.fx = f32(coefficients, at);
    cam.fy = f32(coefficients, at + 4);
    cam.cx = f32(coefficients, at + 8);
    cam.cy = f32(coefficients, at + 12);
    c.depth_modes.push_back(cam);
  }
  // K is stored row-major: fx at 0, ppx at 2, fy at 4, ppy at 5.
  c.color_normalized = {f32(rgb, kRgbIntrinsicAt), f32(rgb, kRgbIntrinsicAt + 16),
                        f32(rgb, kRgbIntrinsicAt + 8), f32(rgb, kRgbIntrinsicAt + 20)};
  for (std::size_t i = 0; i < 5; ++i)
    c.color_distortion[i] = f32(rgb, kRgbDistortionAt + 4 * i);
  c.color_calib_width = read_le<std::uint16_t>(rgb, kRgbCalibSizeAt, "calib width");
  c.color_calib_height = read_le<std::uint16_t>(rgb, kRgbCalibSizeAt + 2, "calib height");
  Eigen::Matrix3d r;
  // Column-major, as the firmware's 3x3 matrices are.
  for (int col = 0; col < 3; ++col)
    for (int row = 0; row < 3; ++row)
      r(row, col) = f32(rgb, kRgbRotationRectAt + 4 * static_cast<std::size_t>(3 * col + row));
  Eigen::Vector3d t;
  for (int i = 0; i < 3; ++i)
    t[i] = -1e-3 * f32(rgb, kRgbTranslationRectAt +
                                4 * static_cast<std::size_t>(i));  // mm, stored with opposite sign
  if (!r.allFinite() || std::abs(r.determinant() - 1.0) > 1e-3)
    throw Error("calibration table 32 (RGB): the depth-to-colour rotation is not a rotation",
                {.field = "rotation_matrix_rect", .offset = kRgbRotationRectAt});
  c.color_from_depth = SE3(SO3(Eigen::Quaterniond(r).normalized()), t);
  if (c.depth_modes.empty())
    throw Error("calibration table 25 has no depth intrinsics",
                {.field = "rect_params", .offset = kRectParamsAt});
  return c;
}

std::vector<std::uint8_t> build_coefficients_table(const DepthColorCalibration& c) {
  std::vector<std::uint8_t> t(kCoefficientsBytes, 0);
  write_le<float>(t, kBaselineAt, static_cast<float>(-c.baseline_m * 1e3));
  write_le<std::uint32_t>(t, kBaselineAt + 4, 1);  // Brown model
  for (const PinholeCamera& cam : c.depth_modes) {
    for (std::size_t i = 0; i < kRectResolutions.size(); ++i) {
      if (kRectResolutions[i][0] != cam.width || kRectResolutions[i][1] != cam.height) continue;
      const std::size_t at = kRectParamsAt + 16 * i;
      write_le<float>(t, at, static_cast<float>(cam.fx));
      write_le<float>(t, at + 4, static_cast<float>(cam.fy));
      write_le<float>(t, at + 8, static_cast<float>(cam.cx));
      write_le<float>(t, at + 12, static_cast<float>(cam.cy));
    }
  }
  return with_header(std::move(t), kTableCoefficients);
}

std::vector<std::uint8_t> build_rgb_table(const DepthColorCalibration& c) {
  std::vector<std::uint8_t> t(kRgbBytes, 0);
  const auto& n = c.color_normalized;
  write_le<float>(t, kRgbIntrinsicAt, static_cast<float>(n[0]));
  write_le<float>(t, kRgbIntrinsicAt + 8, static_cast<float>(n[2]));
  write_le<float>(t, kRgbIntrinsicAt + 16, static_cast<float>(n[1]));
  write_le<float>(t, kRgbIntrinsicAt + 20, static_cast<float>(n[3]));
  write_le<float>(t, kRgbIntrinsicAt + 32, 1.0f);
  for (std::size_t i = 0; i < 5; ++i)
    write_le<float>(t, kRgbDistortionAt + 4 * i, static_cast<float>(c.color_distortion[i]));
  write_le<std::uint16_t>(t, kRgbCalibSizeAt, static_cast<std::uint16_t>(c.color_calib_width));
  write_le<std::uint16_t>(t, kRgbCalibSizeAt + 2, static_cast<std::uint16_t>(c.color_calib_height));
  const Eigen::Matrix3d r = c.color_from_depth.rotation();
  for (int col = 0; col < 3; ++col)
    for (int row = 0; row < 3; ++row)
      write_le<float>(t, kRgbRotationRectAt + 4 * static_cast<std::size_t>(3 * col + row),
                      static_cast<float>(r(row, col)));
  for (int i = 0; i < 3; ++i)
    write_le<float>(t, kRgbTranslationRectAt + 4 * static_cast<std::size_t>(i),
                    static_cast<float>(-1e3 * c.color_from_depth.translation()[i]));
  return with_header(std::move(t), kTableRgb);
}

DepthColorCalibration nominal_d455_calibration() {
  DepthColorCalibration c;
  c.baseline_m = 0.095;
  c.depth_modes = {{848, 480, 428.0, 428.0, 423.5, 239.0, {}},
                   {640, 480, 385.5, 385.5, 319.5, 239.0, {}},
                   {1280, 720, 642.0, 642.0, 639.5, 358.5, {}}};
  // 1280x800 calibration, about 640 px focal length at 1280 wide (D455 colour, 90 deg HFOV).
  c.color_calib_width = 1280;
  c.color_calib_height = 800;
  c.color_normalized = {640.0 / 640.0, 640.0 / 400.0, 0.5 / 640.0, -1.5 / 400.0};
  c.color_distortion = {-0.055, 0.065, 0.0004, 0.0006, -0.021};
  c.color_from_depth =
      SE3(SO3(Eigen::Quaterniond(Eigen::AngleAxisd(0.002, Eigen::Vector3d::UnitY()))),
          Eigen::Vector3d(-0.059, 0.0002, 0.0004));
  return c;
}

namespace {

DepthColorCalibration read_calibration_text(const std::filesystem::path& path, int depth_width,
                                            int depth_height) {
  // Through the YAML guard: OpenCV's reader can loop forever, a FIFO never ends.
  const std::string text = read_yaml_text(path, "camera file");
  cv::FileStorage fs;
  try {
    fs.open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY);
  } catch (const cv::Exception& e) {
    throw Error("cannot parse camera file: " + e.msg, {.file = path.string()});
  }
  if (!fs.isOpened()) throw Error("cannot open camera file", {.file = path.string()});
  auto number = [&](const std::string& key, std::optional<double> fallback = {}) {
    const cv::FileNode n = fs[key];
    if (n.empty() && fallback) return *fallback;
    if (!n.isReal() && !n.isInt())
      throw Error("missing or non-numeric key", {.file = path.string(), .field = key});
    return static_cast<double>(n);
  };
  DepthColorCalibration c;
  const double w = number("Camera.width"), h = number("Camera.height");
  c.color_calib_width = static_cast<int>(w);
  c.color_calib_height = static_cast<int>(h);
  c.color_normalized = {number("Camera1.fx") / (w / 2), number("Camera1.fy") / (h / 2),
                        number("Camera1.cx") / (w / 2) - 1.0, number("Camera1.cy") / (h / 2) - 1.0};
  const char* dist[5] = {"Camera1.k1", "Camera1.k2", "Camera1.p1", "Camera1.p2", "Camera1.k3"};
  for (int i = 0; i < 5; ++i)
    c.color_distortion[i] = number(dist[i], 0.0);
  c.color_distortion_inverse = false;  // OpenCV / ORB-SLAM coefficients distort
  PinholeCamera depth = c.color_camera(depth_width, depth_height);  // registered: same camera
  depth.distortion = {};
  if (!fs["Depth.fx"].empty()) {
    depth = {static_cast<int>(number("Depth.width")),
             static_cast<int>(number("Depth.height")),
             number("Depth.fx"),
             number("Depth.fy"),
             number("Depth.cx"),
             number("Depth.cy"),
             {}};
  }
  c.depth_modes = {depth};
  if (const auto pose = settings::read_rigid_matrix(
          fs["color_from_depth"], {.file = path.string(), .field = "color_from_depth"}))
    c.color_from_depth = *pose;
  return c;
}

}  // namespace

DepthColorCalibration load_calibration_file(const std::filesystem::path& path, int depth_width,
                                            int depth_height) {
  return read_naming_file(path, "camera file",
                          [&] { return read_calibration_text(path, depth_width, depth_height); });
}

}  // namespace coloc::capture
