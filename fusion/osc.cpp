#include "fusion/osc.hpp"

#include <lo/lo.h>

#include <array>
#include <cmath>
#include <cstring>
#include <memory>

#include "fusion/osc_wire.hpp"

namespace coloc::fusion {
namespace {

constexpr int kMaxBundleDepth = 4;
constexpr double kNtpFromUnix = 2208988800.0;  // seconds from 1900-01-01 to 1970-01-01

struct MessageDeleter {
  void operator()(lo_message m) const { lo_message_free(m); }
};
using MessagePtr = std::unique_ptr<std::remove_pointer_t<lo_message>, MessageDeleter>;

std::uint32_t read_be32(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) |
         std::uint32_t{p[3]};
}

void append_be32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8)
    out.push_back(static_cast<std::uint8_t>(v >> shift));
}

void set_error(OscDecodeResult& result, OscError error, std::string detail) {
  if (result.error != OscError::kNone) return;
  result.error = error;
  result.detail = std::move(detail);
}

bool is_coloc_pose_address(std::string_view address) {
  return address == kPoseAddress || address == kXrPoseAddress || address == kFusedPoseAddress;
}

// liblo's argument pointers point into the packet, 4-byte aligned, while lo_arg (a union with
// doubles) wants 8: read through memcpy instead of argv[i]->d.
template <typename T>
T read_arg(lo_arg* arg) {
  T value;
  std::memcpy(&value, static_cast<const void*>(arg), sizeof(T));
  return value;
}

void decode_pose_arguments(lo_message m, OscMessage& out, OscDecodeResult& result) {
  lo_arg** argv = lo_message_get_argv(m);
  PoseMessage& p = out.pose;
  p.time = read_arg<double>(argv[0]);
  p.sequence = read_arg<std::int32_t>(argv[1]);
  p.state = read_arg<std::int32_t>(argv[2]);
  p.position = {read_arg<float>(argv[3]), read_arg<float>(argv[4]), read_arg<float>(argv[5])};
  Eigen::Vector4d q(read_arg<float>(argv[6]), read_arg<float>(argv[7]), read_arg<float>(argv[8]),
                    read_arg<float>(argv[9]));
  if (!std::isfinite(p.time) || !p.position.allFinite() || !q.allFinite()) {
    set_error(result, OscError::kInvalidValue, out.address + ": non-finite value");
    return;
  }
  // float32 quaternions from engines are unit to ~1e-7; anything far off is a bug upstream.
  if (std::abs(q.norm() - 1.0) > 1e-2) {
    set_error(result, OscError::kInvalidValue,
              out.address + ": quaternion norm " + std::to_string(q.norm()) + " is not 1");
    return;
  }
  q.normalize();
  p.orientation = Eigen::Quaterniond(q[3], q[0], q[1], q[2]);
  result.messages.push_back(std::move(out));
}

void decode_message(const std::uint8_t* data, std::size_t size, OscDecodeResult& result) {
  // liblo wants a mutable buffer; copy so the caller's packet stays untouched.
  std::array<std::uint8_t, 4096> copy{};
  if (size > copy.size()) {
    set_error(result, OscError::kOversized, "message larger than 4096 bytes");
    return;
  }
  // liblo reads whatever the type tags promise; it only gets messages whose every argument is
  // known to lie inside the datagram.
  if (const std::string reason = check_osc_message(data, size); !reason.empty()) {
    set_error(result, OscError::kMalformed, "not an OSC message: " + reason);
    return;
  }
  std::memcpy(copy.data(), data, size);
  int code = 0;
  MessagePtr m(lo_message_deserialise(copy.data(), size, &code));
  if (!m) {
    set_error(result, OscError::kMalformed,
              "not an OSC message (liblo error " + std::to_string(code) + ")");
    return;
  }
  OscMessage out;
  out.address = lo_get_path(copy.data(), static_cast<ssize_t>(size));
  if (out.address.empty() || out.address.front() != '/') {
    set_error(result, OscError::kMalformed, "address does not start with '/'");
    return;
  }
  const std::string types = lo_message_get_types(m.get());
  if (is_coloc_pose_address(out.address)) {
    if (types != kPoseTypes) {
      set_error(
          result, OscError::kWrongTypes,
          out.address + ": type tags '" + types + "', expected '" + std::string(kPoseTypes) + "'");
      return;
    }
    decode_pose_arguments(m.get(), out, result);
  } else if (out.address == kGetPoseAddress) {
    if (types == "i") {
      const int port = read_arg<std::int32_t>(lo_message_get_argv(m.get())[0]);
      if (port <= 0 || port > 65535) {
        set_error(result, OscError::kInvalidValue, "get_pose: reply port out of range");
        return;
      }
      out.reply_port = port;
    } else if (!types.empty()) {
      set_error(result, OscError::kWrongTypes,
                "/coloc/get_pose: type tags '" + types + "', expected '' or 'i'");
      return;
    }
    result.messages.push_back(std::move(out));
  } else {
    set_error(result, OscError::kUnknownAddress, "unknown address '" + out.address + "'");
  }
}

void decode_element(const std::uint8_t* data, std::size_t size, int depth,
                    OscDecodeResult& result) {
  static constexpr char kBundleTag[] = "#bundle";  // 8 bytes with its terminating zero
  if (size < 8 || size % 4 != 0) {
    set_error(result, OscError::kMalformed,
              "size " + std::to_string(size) + " is not a positive multiple of 4");
    return;
  }
  if (std::memcmp(data, kBundleTag, 8) != 0) {
    decode_message(data, size, result);
    return;
  }
  if (depth >= kMaxBundleDepth) {
    set_error(result, OscError::kMalformed, "bundles nested too deeply");
    return;
  }
  std::size_t offset = 16;  // "#bundle\0" + 8-byte timetag
  if (size < offset) {
    set_error(result, OscError::kMalformed, "bundle shorter than its header");
    return;
  }
  while (offset < size) {
    if (size - offset < 4) {
      set_error(result, OscError::kMalformed, "bundle element size cut off");
      return;
    }
    const std::size_t element = read_be32(data + offset);
    offset += 4;
    if (element > size - offset) {
      set_error(result, OscError::kMalformed,
                "bundle element of " + std::to_string(element) + " bytes overruns the packet");
      return;
    }
    decode_element(data + offset, element, depth + 1, result);
    offset += element;
  }
}

}  // namespace

PoseMessage PoseMessage::from_pose(double time, std::int32_t sequence, std::int32_t state,
                                   const SE3& pose) {
  return {time, sequence, state, pose.translation(), pose.quaternion()};
}

const char* to_string(OscError error) {
  switch (error) {
    case OscError::kNone:
      return "none";
    case OscError::kOversized:
      return "oversized";
    case OscError::kMalformed:
      return "malformed";
    case OscError::kUnknownAddress:
      return "unknown address";
    case OscError::kWrongTypes:
      return "wrong types";
    case OscError::kInvalidValue:
      return "invalid value";
  }
  return "unknown";
}

std::vector<std::uint8_t> encode_pose(std::string_view address, const PoseMessage& pose,
                                      bool as_bundle) {
  MessagePtr m(lo_message_new());
  const Eigen::Quaterniond& q = pose.orientation;
  lo_message_add_double(m.get(), pose.time);
  lo_message_add_int32(m.get(), pose.sequence);
  lo_message_add_int32(m.get(), pose.state);
  for (int i = 0; i < 3; ++i)
    lo_message_add_float(m.get(), static_cast<float>(pose.position[i]));
  lo_message_add_float(m.get(), static_cast<float>(q.x()));
  lo_message_add_float(m.get(), static_cast<float>(q.y()));
  lo_message_add_float(m.get(), static_cast<float>(q.z()));
  lo_message_add_float(m.get(), static_cast<float>(q.w()));
  const std::string path(address);
  std::vector<std::uint8_t> bytes;
  if (!as_bundle) {
    bytes.resize(lo_message_length(m.get(), path.c_str()));
    lo_message_serialise(m.get(), path.c_str(), bytes.data(), nullptr);
    return bytes;
  }
  // Bundle framing is four fixed fields; written here so liblo's bundle reference counting
  // stays out of the picture: "#bundle\0", NTP timetag, element size, element.
  bytes.resize(lo_message_length(m.get(), path.c_str()));
  lo_message_serialise(m.get(), path.c_str(), bytes.data(), nullptr);
  const double ntp = pose.time + kNtpFromUnix;
  const auto seconds = static_cast<std::uint32_t>(std::floor(ntp));
  const auto fraction = static_cast<std::uint32_t>((ntp - std::floor(ntp)) * 4294967296.0);
  std::vector<std::uint8_t> bundle = {'#', 'b', 'u', 'n', 'd', 'l', 'e', 0};
  append_be32(bundle, seconds);
  append_be32(bundle, fraction);
  append_be32(bundle, static_cast<std::uint32_t>(bytes.size()));
  bundle.insert(bundle.end(), bytes.begin(), bytes.end());
  return bundle;
}

std::vector<std::uint8_t> encode_get_pose(int reply_port) {
  MessagePtr m(lo_message_new());
  if (reply_port > 0) lo_message_add_int32(m.get(), reply_port);
  const std::string path(kGetPoseAddress);
  std::vector<std::uint8_t> bytes(lo_message_length(m.get(), path.c_str()));
  lo_message_serialise(m.get(), path.c_str(), bytes.data(), nullptr);
  return bytes;
}

OscDecodeResult decode_packet(const std::uint8_t* data, std::size_t size, std::size_t max_size) {
  OscDecodeResult result;
  if (size > max_size) {
    set_error(result, OscError::kOversized,
              "packet of " + std::to_string(size) + " bytes exceeds " + std::to_string(max_size));
    return result;
  }
  decode_element(data, size, 0, result);
  return result;
}

}  // namespace coloc::fusion
