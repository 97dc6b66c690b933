#pragma once
// The OSC messages `coloc session` takes (README "Shared sessions"). The pose messages keep the
// documented `diifffffff` shape; what the session adds comes after it, so the existing
// messages stay valid as they are:
//
//   /coloc/xr_pose       diifffffff[s]    head pose vr_from_head of participant s
//   /coloc/xr_controller diifffffffi[s]   controller pose vr_from_controller, index i
//   /coloc/pose          diifffffff[s]    global pose world_from_head of participant s (drift
//                                         correction); on the anchor port: the anchor camera
//   /coloc/get_pose      [s][i]           current poses of participant s (all without s), sent
//                                         to port i of the sender (its own port without i)
//   /coloc/session/reload s               re-read participant s's calibration file now
//
// Without the trailing participant id a pose message belongs to the participant whose own port
// received it (ParticipantConfig::port). Decoding never throws: malformed input is an error
// value (counted by the node).

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "fusion/osc.hpp"

namespace coloc::fusion::session {

inline constexpr std::string_view kControllerAddress = "/coloc/xr_controller";
inline constexpr std::string_view kReloadAddress = "/coloc/session/reload";

enum class MessageKind : std::uint8_t { kHead, kController, kGlobal, kGetPose, kReload };

struct SessionMessage {
  MessageKind kind = MessageKind::kHead;
  std::string participant;  // empty: untagged (the receiving port decides)
  int controller = 0;
  PoseMessage pose;
  int reply_port = 0;  // get_pose: 0 = the sender's port
};

// Counts of what was dropped, by reason (a snapshot is part of the node's statistics).
struct WireStats {
  std::uint64_t packets = 0;
  std::uint64_t messages = 0;
  std::uint64_t oversized = 0;
  std::uint64_t malformed = 0;
  std::uint64_t unknown_address = 0;
  std::uint64_t wrong_types = 0;
  std::uint64_t invalid_values = 0;
  std::string last_error;
};

struct WireResult {
  OscError error = OscError::kNone;  // first error met; messages decoded before it are kept
  std::string detail;
  std::vector<SessionMessage> messages;
};

// Decodes one datagram (a message or a bundle of them, nested at most 4 deep).
WireResult decode_session_packet(const std::uint8_t* data, std::size_t size,
                                 std::size_t max_size = kDefaultMaxPacketSize);
// Adds a result's error to the counters.
void count(WireStats& stats, const WireResult& result);

// Encoders for clients and tests (the session's outputs use fusion::encode_pose).
std::vector<std::uint8_t> encode_head(const PoseMessage& pose, const std::string& participant);
std::vector<std::uint8_t> encode_controller(const PoseMessage& pose, int index,
                                            const std::string& participant);
std::vector<std::uint8_t> encode_global(const PoseMessage& pose, const std::string& participant);
std::vector<std::uint8_t> encode_get(const std::string& participant, int reply_port);

}  // namespace coloc::fusion::session
