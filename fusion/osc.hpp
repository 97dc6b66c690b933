#pragma once
// The OSC 1.0 pose messages of coloc and their encoding (liblo). One shape for all three pose
// messages, so any OSC client (and liblo's `oscsend`) can speak it; see README "OSC address
// space":
//
//   /coloc/pose        global pose from the localizer (world_from_head, scan frame)
//   /coloc/xr_pose     headset pose into the fuser (xr_from_head, headset frame)
//   /coloc/fused_pose  fused pose out of the fuser (world_from_head)
//   type tags "diifffffff": time (s, exposure or sample time on the sender's clock), sequence
//   number, tracking state (0 lost, 1 tracking, 2 just relocalized, 3 visual odometry outside
//   the map), position x y z (m), quaternion x y z w.
//
//   /coloc/get_pose    on-demand request, no arguments (reply to the sender's address and port)
//                      or "i" = the port to reply to on the sender's host (for one-shot senders
//                      such as oscsend that cannot receive).
//
// A packet may also be an OSC bundle (its timetag = the exposure time); its messages are decoded
// one by one. Decoding never throws: malformed input is an error value with a reason.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "slam/core/se3.hpp"

namespace coloc::fusion {

inline constexpr std::string_view kPoseAddress = "/coloc/pose";
inline constexpr std::string_view kXrPoseAddress = "/coloc/xr_pose";
inline constexpr std::string_view kFusedPoseAddress = "/coloc/fused_pose";
inline constexpr std::string_view kGetPoseAddress = "/coloc/get_pose";
inline constexpr std::string_view kPoseTypes = "diifffffff";

// Packets larger than this are dropped unread (a pose message is 68 bytes).
inline constexpr std::size_t kDefaultMaxPacketSize = 1024;

struct PoseMessage {
  double time = 0.0;                                   // seconds on the sender's clock
  std::int32_t sequence = 0;                           // increases by one per message of a stream
  std::int32_t state = 1;                              // TrackingState / FusionState as an integer
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // metres
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  // unit

  SE3 pose() const { return SE3(orientation, position); }
  static PoseMessage from_pose(double time, std::int32_t sequence, std::int32_t state,
                               const SE3& pose);
};

enum class OscError : std::uint8_t {
  kNone = 0,
  kOversized,       // larger than the allowed packet size
  kMalformed,       // not OSC 1.0 (bad size, padding, path, type string or bundle)
  kUnknownAddress,  // valid OSC, but not a /coloc address we handle
  kWrongTypes,      // a /coloc address with the wrong type tags
  kInvalidValue,    // non-finite numbers or a quaternion that is not (close to) unit
};

const char* to_string(OscError error);

// One decoded message. For pose addresses `pose` holds the (normalized) pose; for get_pose
// `reply_port` is the requested port (0 = reply to the sender's port).
struct OscMessage {
  std::string address;
  PoseMessage pose;
  int reply_port = 0;
};

struct OscDecodeResult {
  OscError error = OscError::kNone;  // first error met; messages decoded before it are kept
  std::string detail;                // human-readable reason
  std::vector<OscMessage> messages;
};

// True when every number of `pose` is finite: only such a pose may go on the wire.
bool finite_message(const PoseMessage& pose);
// What is sent in place of a pose with a non-finite number: its sequence, its time (0 when not
// finite), state 0 (lost) and the identity pose. A receiver then sees a lost tracker, never a
// NaN it would put into a scene.
PoseMessage lost_message(const PoseMessage& pose);

// Serializes one pose message (plain message, or a bundle whose timetag is `time` taken as Unix
// seconds when as_bundle is true). A pose with a non-finite number is sent as lost_message();
// the senders count it (OscStats::non_finite, SessionNodeStats::non_finite).
std::vector<std::uint8_t> encode_pose(std::string_view address, const PoseMessage& pose,
                                      bool as_bundle = false);
// Serializes a /coloc/get_pose request (reply_port 0 = no argument).
std::vector<std::uint8_t> encode_get_pose(int reply_port = 0);

// Decodes a received datagram. Thread-safe (no shared state).
OscDecodeResult decode_packet(const std::uint8_t* data, std::size_t size,
                              std::size_t max_size = kDefaultMaxPacketSize);

}  // namespace coloc::fusion
