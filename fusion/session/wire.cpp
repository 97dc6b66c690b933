#include "fusion/session/wire.hpp"

#include <lo/lo.h>

#include <array>
#include <cmath>
#include <cstring>
#include <memory>

#include "fusion/osc_wire.hpp"

namespace coloc::fusion::session {
namespace {

constexpr int kMaxBundleDepth = 4;

struct MessageDeleter {
  void operator()(lo_message m) const { lo_message_free(m); }
};
using MessagePtr = std::unique_ptr<std::remove_pointer_t<lo_message>, MessageDeleter>;

void fail(WireResult& r, OscError error, std::string detail) {
  if (r.error != OscError::kNone) return;
  r.error = error;
  r.detail = std::move(detail);
}

// liblo's argument pointers are 4-byte aligned inside the packet; lo_arg wants 8 for doubles.
template <typename T>
T read_arg(lo_arg* arg) {
  T value;
  std::memcpy(&value, static_cast<const void*>(arg), sizeof(T));
  return value;
}

// The ten pose arguments from argv[0..9]; false (with the error set) for non-finite values or
// a quaternion that is not unit.
bool read_pose(lo_arg** argv, const std::string& address, PoseMessage& p, WireResult& r) {
  p.time = read_arg<double>(argv[0]);
  p.sequence = read_arg<std::int32_t>(argv[1]);
  p.state = read_arg<std::int32_t>(argv[2]);
  p.position = {read_arg<float>(argv[3]), read_arg<float>(argv[4]), read_arg<float>(argv[5])};
  Eigen::Vector4d q(read_arg<float>(argv[6]), read_arg<float>(argv[7]), read_arg<float>(argv[8]),
                    read_arg<float>(argv[9]));
  if (!std::isfinite(p.time) || !p.position.allFinite() || !q.allFinite()) {
    fail(r, OscError::kInvalidValue, address + ": non-finite value");
    return false;
  }
  if (std::abs(q.norm() - 1.0) > 1e-2) {
    fail(r, OscError::kInvalidValue,
         address + ": quaternion norm " + std::to_string(q.norm()) + " is not 1");
    return false;
  }
  q.normalize();
  p.orientation = Eigen::Quaterniond(q[3], q[0], q[1], q[2]);
  return true;
}

std::string read_string(lo_arg* arg) {
  return std::string(&arg->s);
}

// Pose messages: base types (diifffffff, + i for controllers), optionally + s (participant).
void decode_pose_message(lo_message m, const std::string& address, const std::string& types,
                         MessageKind kind, WireResult& r) {
  const std::string base = kind == MessageKind::kController ? "diifffffffi" : "diifffffff";
  if (types != base && types != base + "s") {
    fail(r, OscError::kWrongTypes,
         address + ": type tags '" + types + "', expected '" + base + "' or '" + base + "s'");
    return;
  }
  lo_arg** argv = lo_message_get_argv(m);
  SessionMessage out;
  out.kind = kind;
  if (!read_pose(argv, address, out.pose, r)) return;
  std::size_t next = 10;
  if (kind == MessageKind::kController) {
    out.controller = read_arg<std::int32_t>(argv[next++]);
    if (out.controller < 0 || out.controller > 255) {
      fail(r, OscError::kInvalidValue, address + ": controller index out of range");
      return;
    }
  }
  if (types.size() > next) {
    out.participant = read_string(argv[next]);
    if (out.participant.empty()) {
      fail(r, OscError::kInvalidValue, address + ": empty participant id");
      return;
    }
  }
  r.messages.push_back(std::move(out));
}

void decode_get(lo_message m, const std::string& types, WireResult& r) {
  if (types != "" && types != "i" && types != "s" && types != "si") {
    fail(r, OscError::kWrongTypes,
         "/coloc/get_pose: type tags '" + types + "', expected '', 'i', 's' or 'si'");
    return;
  }
  lo_arg** argv = lo_message_get_argv(m);
  SessionMessage out;
  out.kind = MessageKind::kGetPose;
  std::size_t next = 0;
  if (!types.empty() && types[0] == 's') out.participant = read_string(argv[next++]);
  if (types.size() > next) {
    out.reply_port = read_arg<std::int32_t>(argv[next]);
    if (out.reply_port <= 0 || out.reply_port > 65535) {
      fail(r, OscError::kInvalidValue, "/coloc/get_pose: reply port out of range");
      return;
    }
  }
  r.messages.push_back(std::move(out));
}

void decode_message(const std::uint8_t* data, std::size_t size, WireResult& r) {
  std::array<std::uint8_t, 4096> copy{};  // liblo wants a mutable buffer
  if (size > copy.size()) {
    fail(r, OscError::kOversized, "message larger than 4096 bytes");
    return;
  }
  // liblo reads whatever the type tags promise (fusion/osc_wire.hpp): it only gets messages
  // whose every argument is known to lie inside the datagram.
  if (const std::string reason = check_osc_message(data, size); !reason.empty()) {
    fail(r, OscError::kMalformed, "not an OSC message: " + reason);
    return;
  }
  std::memcpy(copy.data(), data, size);
  int code = 0;
  MessagePtr m(lo_message_deserialise(copy.data(), size, &code));
  if (!m) {
    fail(r, OscError::kMalformed, "not an OSC message (liblo error " + std::to_string(code) + ")");
    return;
  }
  const std::string address = lo_get_path(copy.data(), static_cast<ssize_t>(size));
  const std::string types = lo_message_get_types(m.get());
  if (address == kXrPoseAddress) {
    decode_pose_message(m.get(), address, types, MessageKind::kHead, r);
  } else if (address == kControllerAddress) {
    decode_pose_message(m.get(), address, types, MessageKind::kController, r);
  } else if (address == kPoseAddress) {
    decode_pose_message(m.get(), address, types, MessageKind::kGlobal, r);
  } else if (address == kGetPoseAddress) {
    decode_get(m.get(), types, r);
  } else if (address == kReloadAddress) {
    if (types != "s") {
      fail(r, OscError::kWrongTypes,
           "/coloc/session/reload: type tags '" + types + "', expected 's'");
      return;
    }
    SessionMessage out;
    out.kind = MessageKind::kReload;
    out.participant = read_string(lo_message_get_argv(m.get())[0]);
    r.messages.push_back(std::move(out));
  } else {
    fail(r, OscError::kUnknownAddress, "unknown address '" + address + "'");
  }
}

std::uint32_t read_be32(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) |
         std::uint32_t{p[3]};
}

void decode_element(const std::uint8_t* data, std::size_t size, int depth, WireResult& r) {
  static constexpr char kBundleTag[] = "#bundle";
  if (size < 8 || size % 4 != 0) {
    fail(r, OscError::kMalformed,
         "size " + std::to_string(size) + " is not a positive multiple of 4");
    return;
  }
  if (std::memcmp(data, kBundleTag, 8) != 0) {
    decode_message(data, size, r);
    return;
  }
  if (depth >= kMaxBundleDepth || size < 16) {
    fail(r, OscError::kMalformed, "bundle nested too deeply or shorter than its header");
    return;
  }
  for (std::size_t offset = 16; offset < size;) {
    if (size - offset < 4) {
      fail(r, OscError::kMalformed, "bundle element size cut off");
      return;
    }
    const std::size_t element = read_be32(data + offset);
    offset += 4;
    if (element > size - offset) {
      fail(r, OscError::kMalformed, "bundle element overruns the packet");
      return;
    }
    decode_element(data + offset, element, depth + 1, r);
    offset += element;
  }
}

MessagePtr pose_message(const PoseMessage& pose) {
  MessagePtr m(lo_message_new());
  const Eigen::Quaterniond& q = pose.orientation;
  lo_message_add_double(m.get(), pose.time);
  lo_message_add_int32(m.get(), pose.sequence);
  lo_message_add_int32(m.get(), pose.state);
  for (int i = 0; i < 3; ++i)
    lo_message_add_float(m.get(), static_cast<float>(pose.position[i]));
  for (const double v : {q.x(), q.y(), q.z(), q.w()})
    lo_message_add_float(m.get(), static_cast<float>(v));
  return m;
}

std::vector<std::uint8_t> serialise(lo_message m, std::string_view address) {
  const std::string path(address);
  std::vector<std::uint8_t> bytes(lo_message_length(m, path.c_str()));
  lo_message_serialise(m, path.c_str(), bytes.data(), nullptr);
  return bytes;
}

}  // namespace

WireResult decode_session_packet(const std::uint8_t* data, std::size_t size, std::size_t max_size) {
  WireResult r;
  if (size > max_size) {
    fail(r, OscError::kOversized,
         "packet of " + std::to_string(size) + " bytes exceeds " + std::to_string(max_size));
    return r;
  }
  decode_element(data, size, 0, r);
  return r;
}

void count(WireStats& stats, const WireResult& result) {
  ++stats.packets;
  stats.messages += result.messages.size();
  switch (result.error) {
    case OscError::kNone:
      return;
    case OscError::kOversized:
      ++stats.oversized;
      break;
    case OscError::kMalformed:
      ++stats.malformed;
      break;
    case OscError::kUnknownAddress:
      ++stats.unknown_address;
      break;
    case OscError::kWrongTypes:
      ++stats.wrong_types;
      break;
    case OscError::kInvalidValue:
      ++stats.invalid_values;
      break;
  }
  stats.last_error = result.detail;
}

std::vector<std::uint8_t> encode_head(const PoseMessage& pose, const std::string& participant) {
  MessagePtr m = pose_message(pose);
  if (!participant.empty()) lo_message_add_string(m.get(), participant.c_str());
  return serialise(m.get(), kXrPoseAddress);
}

std::vector<std::uint8_t> encode_controller(const PoseMessage& pose, int index,
                                            const std::string& participant) {
  MessagePtr m = pose_message(pose);
  lo_message_add_int32(m.get(), index);
  if (!participant.empty()) lo_message_add_string(m.get(), participant.c_str());
  return serialise(m.get(), kControllerAddress);
}

std::vector<std::uint8_t> encode_global(const PoseMessage& pose, const std::string& participant) {
  MessagePtr m = pose_message(pose);
  if (!participant.empty()) lo_message_add_string(m.get(), participant.c_str());
  return serialise(m.get(), kPoseAddress);
}

std::vector<std::uint8_t> encode_get(const std::string& participant, int reply_port) {
  MessagePtr m(lo_message_new());
  if (!participant.empty()) lo_message_add_string(m.get(), participant.c_str());
  if (reply_port > 0) lo_message_add_int32(m.get(), reply_port);
  return serialise(m.get(), kGetPoseAddress);
}

}  // namespace coloc::fusion::session
