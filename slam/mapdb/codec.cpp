#include "slam/mapdb/codec.hpp"

#include <bit>

#include "slam/core/error.hpp"
#include "slam/mapdb/schema.hpp"

namespace coloc::slam::mapdb::detail {

namespace {

void put(Bytes& out, std::uint64_t v, int n) {
  for (int i = 0; i < n; ++i)
    out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}

}  // namespace

void put_u16(Bytes& out, std::uint16_t v) {
  put(out, v, 2);
}
void put_u32(Bytes& out, std::uint32_t v) {
  put(out, v, 4);
}
void put_u64(Bytes& out, std::uint64_t v) {
  put(out, v, 8);
}
void put_f32(Bytes& out, float v) {
  put(out, std::bit_cast<std::uint32_t>(v), 4);
}
void put_f64(Bytes& out, double v) {
  put(out, std::bit_cast<std::uint64_t>(v), 8);
}

std::uint64_t ByteReader::uint(std::size_t n) {
  if (at_ + n > bytes_.size()) throw Error("map database: blob read past its end");
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < n; ++i)
    v |= static_cast<std::uint64_t>(bytes_[at_ + i]) << (8 * i);
  at_ += n;
  return v;
}

std::uint8_t ByteReader::u8() {
  return static_cast<std::uint8_t>(uint(1));
}
std::uint16_t ByteReader::u16() {
  return static_cast<std::uint16_t>(uint(2));
}
std::uint32_t ByteReader::u32() {
  return static_cast<std::uint32_t>(uint(4));
}
std::uint64_t ByteReader::u64() {
  return uint(8);
}
float ByteReader::f32() {
  return std::bit_cast<float>(u32());
}
double ByteReader::f64() {
  return std::bit_cast<double>(u64());
}

void encode_keypoints(std::span<const features::Keypoint> keypoints, std::span<const float> depth,
                      std::span<const float> u_right, std::span<const std::uint8_t> outlier,
                      Bytes& out) {
  const std::size_t n = keypoints.size();
  if (depth.size() != n || u_right.size() != n || outlier.size() != n)
    throw Error("map database: a frame's per-keypoint arrays differ in length");
  out.clear();
  out.reserve(n * kKeypointRecordBytes);
  for (std::size_t i = 0; i < n; ++i) {
    const features::Keypoint& k = keypoints[i];
    for (float v : {k.x, k.y, k.ux, k.uy, k.angle, k.response, depth[i], u_right[i]})
      put_f32(out, v);
    out.push_back(static_cast<std::uint8_t>(k.level));
    out.push_back(outlier[i]);
    put_u16(out, 0);
  }
}

void encode_descriptor(const features::Descriptor& d, Bytes& out) {
  for (std::uint64_t w : d)
    put_u64(out, w);
}

void encode_descriptors(const std::vector<features::Descriptor>& descriptors, Bytes& out) {
  out.clear();
  out.reserve(descriptors.size() * kDescriptorBytes);
  for (const auto& d : descriptors)
    encode_descriptor(d, out);
}

void encode_pose(const SE3& pose, Bytes& out) {
  out.clear();
  const Eigen::Quaterniond& q = pose.quaternion();
  const Eigen::Vector3d& t = pose.translation();
  for (double v : {q.x(), q.y(), q.z(), q.w(), t.x(), t.y(), t.z()})
    put_f64(out, v);
}

void encode_f32s(const std::vector<float>& values, Bytes& out) {
  out.clear();
  for (float v : values)
    put_f32(out, v);
}

void encode_f64s(std::span<const double> values, Bytes& out) {
  out.clear();
  for (double v : values)
    put_f64(out, v);
}

void encode_u16s(std::span<const std::uint16_t> values, Bytes& out) {
  out.clear();
  out.reserve(2 * values.size());
  for (std::uint16_t v : values)
    put_u16(out, v);
}

KeypointData decode_keypoints(std::span<const std::uint8_t> bytes, std::size_t n) {
  if (bytes.size() != n * kKeypointRecordBytes)
    throw Error("map database: keypoint blob of the wrong size");
  KeypointData d;
  d.keypoints.resize(n);
  d.depth.resize(n);
  d.u_right.resize(n);
  d.outlier.resize(n);
  ByteReader r(bytes);
  for (std::size_t i = 0; i < n; ++i) {
    features::Keypoint& k = d.keypoints[i];
    k.x = r.f32();
    k.y = r.f32();
    k.ux = r.f32();
    k.uy = r.f32();
    k.angle = r.f32();
    k.response = r.f32();
    d.depth[i] = r.f32();
    d.u_right[i] = r.f32();
    k.level = r.u8();
    d.outlier[i] = r.u8();
    r.u16();
  }
  return d;
}

features::Descriptor decode_descriptor(std::span<const std::uint8_t> bytes) {
  ByteReader r(bytes);
  features::Descriptor d;
  for (auto& w : d)
    w = r.u64();
  return d;
}

std::vector<features::Descriptor> decode_descriptors(std::span<const std::uint8_t> bytes,
                                                     std::size_t n) {
  if (bytes.size() != n * kDescriptorBytes)
    throw Error("map database: descriptor blob of the wrong size");
  std::vector<features::Descriptor> out(n);
  for (std::size_t i = 0; i < n; ++i)
    out[i] = decode_descriptor(bytes.subspan(i * kDescriptorBytes, kDescriptorBytes));
  return out;
}

SE3 decode_pose(std::span<const std::uint8_t> bytes) {
  ByteReader r(bytes);
  const double qx = r.f64(), qy = r.f64(), qz = r.f64(), qw = r.f64();
  const double tx = r.f64(), ty = r.f64(), tz = r.f64();
  return {SO3::from_unit_quaternion(Eigen::Quaterniond(qw, qx, qy, qz)),
          Eigen::Vector3d(tx, ty, tz)};
}

std::vector<float> decode_f32s(std::span<const std::uint8_t> bytes) {
  ByteReader r(bytes);
  std::vector<float> out(bytes.size() / 4);
  for (float& v : out)
    v = r.f32();
  return out;
}

std::vector<double> decode_f64s(std::span<const std::uint8_t> bytes) {
  ByteReader r(bytes);
  std::vector<double> out(bytes.size() / 8);
  for (double& v : out)
    v = r.f64();
  return out;
}

std::vector<std::uint16_t> decode_u16s(std::span<const std::uint8_t> bytes) {
  ByteReader r(bytes);
  std::vector<std::uint16_t> out(bytes.size() / 2);
  for (std::uint16_t& v : out)
    v = r.u16();
  return out;
}

}  // namespace coloc::slam::mapdb::detail
