#pragma once
// The session description of `coloc session` (README "Shared sessions"): where the anchor camera
// stands in the world (the scan's frame) and, for each participant, its XR system, the hand-eye
// calibration that ties that system's tracking space to the anchor camera, and where its OSC
// poses come from. YAML; unknown keys, missing keys and bad values are coloc::Error naming the
// file, the line and the field (`participants[1].calibration`).
//
// Frames: `world` = the scan's frame, `camera` = the anchor camera, `vr` = one participant's
// tracking space (each system has its own, with its own origin and drift). A participant's
// system is placed by world_from_vr = world_from_camera * vr_from_camera^-1.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "slam/core/se3.hpp"

namespace coloc::fusion::session {

enum class ParticipantKind : std::uint8_t { kVr, kAr, kMr };
const char* to_string(ParticipantKind kind);

// How world_from_camera is known.
enum class AnchorMode : std::uint8_t {
  kFixed,     // given directly (world_from_camera), or from a marker on the floor
              // (world_from_marker * camera_from_marker^-1), computed when the file is read
  kLocalize,  // the camera localized in the registered map: `coloc localize` sends its
              // /coloc/pose (world_from_cam) to localize_port; the first localize_poses are
              // averaged (the camera stands still), and participants are placed from then on
};

struct AnchorConfig {
  std::string camera = "anchor";  // a name for logs
  AnchorMode mode = AnchorMode::kFixed;
  SE3 world_from_camera;    // kFixed
  int localize_port = 0;    // kLocalize: UDP port of the session receiving the camera's poses
  int localize_poses = 30;  // kLocalize: poses averaged before the anchor is set
};

struct ParticipantConfig {
  std::string id;  // [A-Za-z0-9_-]+, the <id> of /coloc/users/<id>/...
  ParticipantKind kind = ParticipantKind::kVr;
  std::string system;                 // free text ("HTC VIVE Pro"), for logs
  std::filesystem::path calibration;  // `coloc handeye solve --output` file (absolute)
  int port = 0;                       // 0: id-tagged messages on the shared port only;
                                      // > 0: also plain (untagged) messages on this port
  int controllers = 2;                // controller indices 0..controllers-1 accepted
  bool drift_correction = true;       // fuse /coloc/pose for this participant if it comes
};

struct SessionConfig {
  std::filesystem::path file;  // where it was read from (empty when built in code)
  AnchorConfig anchor;
  std::vector<ParticipantConfig> participants;
  double stale_after = 0.5;  // s without input before a participant (or controller) is stale

  // Throws coloc::Error naming the field: ids unique and well-formed, ports distinct and in
  // range, controllers in 0..kMaxControllers, stale_after > 0.
  void check() const;
  const ParticipantConfig* find(std::string_view id) const;
};

inline constexpr int kMaxControllers = 16;

// Reads and checks a session YAML file. Relative calibration paths are taken relative to the
// session file's folder.
SessionConfig read_session_config(const std::filesystem::path& path);
// The same from text (`origin` names the source in errors and resolves relative paths).
SessionConfig parse_session_config(const std::string& text, const std::filesystem::path& origin);

}  // namespace coloc::fusion::session
