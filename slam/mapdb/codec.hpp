#pragma once
// Blob layouts of the map file (internal to slam/mapdb). Everything is little-endian, written
// byte by byte, so files move between machines; floats are IEEE 754 bit patterns.
//
//   keypoints (36 bytes per keypoint):  f32 x, y (detected pixel), ux, uy (undistorted pixel),
//       angle (radians), response, depth (metres, <= 0 none), u_right (pixels, < 0 none) |
//       u8 level | u8 outlier | u16 reserved (0)
//   descriptors (32 bytes per keypoint): 4 x u64; bit i of the descriptor is bit i % 64 of
//       word i / 64 (features/descriptor.hpp)
//   pose (56 bytes): f64 qx, qy, qz, qw (unit quaternion, Hamilton), tx, ty, tz (metres)
//   keyframe depth (2 bytes per pixel): u16 millimetres, row by row (0 = no depth)
//   f32 / f64 arrays (scale factors, distortion, a gyro link's 3 x 3 bias Jacobian row by
//       row): the values one after the other
#include <cstdint>
#include <span>
#include <vector>

#include "slam/core/se3.hpp"
#include "slam/features/descriptor.hpp"
#include "slam/features/orb_extractor.hpp"
#include "slam/frame/frame.hpp"

namespace coloc::slam::mapdb::detail {

using Bytes = std::vector<std::uint8_t>;

void put_u16(Bytes& out, std::uint16_t v);
void put_u32(Bytes& out, std::uint32_t v);
void put_u64(Bytes& out, std::uint64_t v);
void put_f32(Bytes& out, float v);
void put_f64(Bytes& out, double v);

// Reads consecutive values; the caller checked the blob's size beforehand, so running past the
// end is a programming error (coloc::Error, never undefined behaviour).
class ByteReader {
 public:
  explicit ByteReader(std::span<const std::uint8_t> bytes) : bytes_(bytes) {}
  std::uint8_t u8();
  std::uint16_t u16();
  std::uint32_t u32();
  std::uint64_t u64();
  float f32();
  double f64();

 private:
  std::uint64_t uint(std::size_t n);
  std::span<const std::uint8_t> bytes_;
  std::size_t at_ = 0;
};

// The per-keypoint data of a frame that a map file keeps.
struct KeypointData {
  std::vector<features::Keypoint> keypoints;
  std::vector<float> depth;
  std::vector<float> u_right;
  std::vector<std::uint8_t> outlier;
};

// Write `out` (cleared first). The keypoint arrays have one entry per keypoint.
void encode_keypoints(std::span<const features::Keypoint> keypoints, std::span<const float> depth,
                      std::span<const float> u_right, std::span<const std::uint8_t> outlier,
                      Bytes& out);
void encode_descriptors(const std::vector<features::Descriptor>& descriptors, Bytes& out);
void encode_descriptor(const features::Descriptor& d, Bytes& out);
void encode_pose(const SE3& pose, Bytes& out);
void encode_f32s(const std::vector<float>& values, Bytes& out);
void encode_f64s(std::span<const double> values, Bytes& out);
void encode_u16s(std::span<const std::uint16_t> values, Bytes& out);

// `bytes` must hold exactly n records.
KeypointData decode_keypoints(std::span<const std::uint8_t> bytes, std::size_t n);
std::vector<features::Descriptor> decode_descriptors(std::span<const std::uint8_t> bytes,
                                                     std::size_t n);
features::Descriptor decode_descriptor(std::span<const std::uint8_t> bytes);
// Bit for bit the pose that was encoded (the quaternion is not renormalized).
SE3 decode_pose(std::span<const std::uint8_t> bytes);
std::vector<float> decode_f32s(std::span<const std::uint8_t> bytes);
std::vector<double> decode_f64s(std::span<const std::uint8_t> bytes);
std::vector<std::uint16_t> decode_u16s(std::span<const std::uint8_t> bytes);

}  // namespace coloc::slam::mapdb::detail
