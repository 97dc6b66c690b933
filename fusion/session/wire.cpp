#include "fusion/session/wire.hpp"

#include <lo/lo.h>

#include <array>
#include <cmath>
#include <cstring>
#include <memory>

#include "fusion/osc_wire.hpp"

namespace coloc::fusion::session {
namespace {

std::string read_string(lo_arg* arg) {
  return std::string(&arg->s);
}

// Pose messages: base types (diifffffff, + i for controllers), optionally + s (participant).
void decode_pose_message(lo_message m, const std::string& address, const std::string& types,
                         MessageKind kind, std::vector<SessionMessage>& messages,
                         OscFailure& failure) {
  const std::string base = kind == MessageKind::kController ? "diifffffffi" : "diifffffff";
  if (types != base && types != base + "s") {
    failure.fail(OscError::kWrongTypes, address + ": type tags '" + types + "', expected '" + base +
                                            "' or '" + base + "s'");
    return;
  }
  lo_arg** argv = lo_message_get_argv(m);
  SessionMessage out;
  out.kind = kind;
  if (!read_osc_pose(argv, address, out.pose, failure)) return;
  std::size_t next = 10;
  if (kind == MessageKind::kController) {
    out.controller = read_osc_arg<std::int32_t>(argv[next++]);
    if (out.controller < 0 || out.controller > 255) {
      failure.fail(OscError::kInvalidValue, address + ": controller index out of range");
      return;
    }
  }
  if (types.size() > next) {
    out.participant = read_string(argv[next]);
    if (out.participant.empty()) {
      failure.fail(OscError::kInvalidValue, address + ": empty participant id");
      return;
    }
  }
  messages.push_back(std::move(out));
}

void decode_get(lo_message m, const std::string& types, std::vector<SessionMessage>& messages,
                OscFailure& failure) {
  if (types != "" && types != "i" && types != "s" && types != "si") {
    failure.fail(OscError::kWrongTypes,
                 "/coloc/get_pose: type tags '" + types + "', expected '', 'i', 's' or 'si'");
    return;
  }
  lo_arg** argv = lo_message_get_argv(m);
  SessionMessage out;
  out.kind = MessageKind::kGetPose;
  std::size_t next = 0;
  if (!types.empty() && types[0] == 's') out.participant = read_string(argv[next++]);
  if (types.size() > next) {
    out.reply_port = read_osc_arg<std::int32_t>(argv[next]);
    if (out.reply_port <= 0 || out.reply_port > 65535) {
      failure.fail(OscError::kInvalidValue, "/coloc/get_pose: reply port out of range");
      return;
    }
  }
  messages.push_back(std::move(out));
}

void decode_message(const OscMessageView& m, std::vector<SessionMessage>& messages,
                    OscFailure& failure) {
  const std::string& address = m.address;
  if (address == kXrPoseAddress) {
    decode_pose_message(m.message, address, m.types, MessageKind::kHead, messages, failure);
  } else if (address == kControllerAddress) {
    decode_pose_message(m.message, address, m.types, MessageKind::kController, messages, failure);
  } else if (address == kPoseAddress) {
    decode_pose_message(m.message, address, m.types, MessageKind::kGlobal, messages, failure);
  } else if (address == kGetPoseAddress) {
    decode_get(m.message, m.types, messages, failure);
  } else if (address == kReloadAddress) {
    if (m.types != "s") {
      failure.fail(OscError::kWrongTypes,
                   "/coloc/session/reload: type tags '" + m.types + "', expected 's'");
      return;
    }
    SessionMessage out;
    out.kind = MessageKind::kReload;
    out.participant = read_string(lo_message_get_argv(m.message)[0]);
    messages.push_back(std::move(out));
  } else {
    failure.fail(OscError::kUnknownAddress, "unknown address '" + address + "'");
  }
}

LoMessagePtr pose_message(const PoseMessage& pose) {
  LoMessagePtr m(lo_message_new());
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
  OscFailure failure = walk_osc_packet(
      data, size, max_size,
      [&](const OscMessageView& m, OscFailure& f) { decode_message(m, r.messages, f); });
  r.error = failure.error;
  r.detail = std::move(failure.detail);
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
  LoMessagePtr m = pose_message(pose);
  if (!participant.empty()) lo_message_add_string(m.get(), participant.c_str());
  return serialise(m.get(), kXrPoseAddress);
}

std::vector<std::uint8_t> encode_controller(const PoseMessage& pose, int index,
                                            const std::string& participant) {
  LoMessagePtr m = pose_message(pose);
  lo_message_add_int32(m.get(), index);
  if (!participant.empty()) lo_message_add_string(m.get(), participant.c_str());
  return serialise(m.get(), kControllerAddress);
}

std::vector<std::uint8_t> encode_global(const PoseMessage& pose, const std::string& participant) {
  LoMessagePtr m = pose_message(pose);
  if (!participant.empty()) lo_message_add_string(m.get(), participant.c_str());
  return serialise(m.get(), kPoseAddress);
}

std::vector<std::uint8_t> encode_get(const std::string& participant, int reply_port) {
  LoMessagePtr m(lo_message_new());
  if (!participant.empty()) lo_message_add_string(m.get(), participant.c_str());
  if (reply_port > 0) lo_message_add_int32(m.get(), reply_port);
  return serialise(m.get(), kGetPoseAddress);
}

}  // namespace coloc::fusion::session
