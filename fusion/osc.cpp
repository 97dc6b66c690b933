#include "fusion/osc.hpp"

#include <lo/lo.h>

#include <array>
#include <cmath>
#include <cstring>
#include <memory>

#include "fusion/osc_wire.hpp"

namespace coloc::fusion {
namespace {

constexpr double kNtpFromUnix = 2208988800.0;  // seconds from 1900-01-01 to 1970-01-01

void append_be32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8)
    out.push_back(static_cast<std::uint8_t>(v >> shift));
}

bool is_coloc_pose_address(std::string_view address) {
  return address == kPoseAddress || address == kXrPoseAddress || address == kFusedPoseAddress;
}

// One walked message: a pose, or a get_pose request; anything else fails the packet.
void decode_message(const OscMessageView& m, std::vector<OscMessage>& messages,
                    OscFailure& failure) {
  if (m.address.empty() || m.address.front() != '/') {
    failure.fail(OscError::kMalformed, "address does not start with '/'");
    return;
  }
  OscMessage out;
  out.address = m.address;
  lo_arg** argv = lo_message_get_argv(m.message);
  if (is_coloc_pose_address(m.address)) {
    if (m.types != kPoseTypes) {
      failure.fail(OscError::kWrongTypes, m.address + ": type tags '" + m.types + "', expected '" +
                                              std::string(kPoseTypes) + "'");
      return;
    }
    if (read_osc_pose(argv, m.address, out.pose, failure)) messages.push_back(std::move(out));
  } else if (m.address == kGetPoseAddress) {
    if (m.types == "i") {
      const int port = read_osc_arg<std::int32_t>(argv[0]);
      if (port <= 0 || port > 65535) {
        failure.fail(OscError::kInvalidValue, "get_pose: reply port out of range");
        return;
      }
      out.reply_port = port;
    } else if (!m.types.empty()) {
      failure.fail(OscError::kWrongTypes,
                   "/coloc/get_pose: type tags '" + m.types + "', expected '' or 'i'");
      return;
    }
    messages.push_back(std::move(out));
  } else {
    failure.fail(OscError::kUnknownAddress, "unknown address '" + m.address + "'");
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

bool finite_message(const PoseMessage& pose) {
  return std::isfinite(pose.time) && pose.position.allFinite() &&
         pose.orientation.coeffs().allFinite();
}

PoseMessage lost_message(const PoseMessage& pose) {
  PoseMessage lost;
  lost.time = std::isfinite(pose.time) ? pose.time : 0.0;
  lost.sequence = pose.sequence;
  lost.state = 0;
  return lost;
}

std::vector<std::uint8_t> encode_pose(std::string_view address, const PoseMessage& checked,
                                      bool as_bundle) {
  // The one encoder of every sender: nothing non-finite leaves it, whoever calls.
  const PoseMessage pose = finite_message(checked) ? checked : lost_message(checked);
  LoMessagePtr m(lo_message_new());
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
  LoMessagePtr m(lo_message_new());
  if (reply_port > 0) lo_message_add_int32(m.get(), reply_port);
  const std::string path(kGetPoseAddress);
  std::vector<std::uint8_t> bytes(lo_message_length(m.get(), path.c_str()));
  lo_message_serialise(m.get(), path.c_str(), bytes.data(), nullptr);
  return bytes;
}

OscDecodeResult decode_packet(const std::uint8_t* data, std::size_t size, std::size_t max_size) {
  OscDecodeResult result;
  OscFailure failure = walk_osc_packet(
      data, size, max_size,
      [&](const OscMessageView& m, OscFailure& f) { decode_message(m, result.messages, f); });
  result.error = failure.error;
  result.detail = std::move(failure.detail);
  return result;
}

}  // namespace coloc::fusion
