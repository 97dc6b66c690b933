#pragma once
// Session: several users of different XR systems placed in one world frame (the scan's), each
// through its own hand-eye calibration to a shared anchor camera (An et al. 2023) and, when global
// poses for it arrive, drift-corrected by its own DriftFuser (Michiels et al. 2024, 5.2).
//
// Per participant: world_from_vr = world_from_camera * vr_from_camera^-1 (calibration file:
// `coloc handeye solve --output`), then
//   head:         world_from_head = C * world_from_vr * vr_from_head
//   controller n: world_from_controller = C * world_from_vr * vr_from_controller
// with C the fuser's applied drift correction (identity until a global pose for that participant
// arrives, or without drift correction). Inputs go in, outputs (OSC messages for
// /coloc/users/<id>/head and /coloc/users/<id>/controller/<n>) come out; no sockets here
// (node.hpp does the I/O), so tests drive it directly.
//
// Clocks: pose times are the sender's (passed through to the outputs); staleness uses `now`, the
// session's own monotonic clock in seconds, since each system has its own clock.
// Thread-safety: none; one owner (SessionNode holds it under its lock).

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fusion/fuser.hpp"
#include "fusion/osc.hpp"
#include "fusion/osc_node.hpp"  // SequenceGuard
#include "fusion/session/config.hpp"
#include "fusion/stream_guard.hpp"
#include "registration/handeye/io.hpp"

namespace coloc::fusion::session {

// The state argument of the /coloc/users/... messages.
enum class UserState : std::int32_t {
  kStale = 0,       // nothing received for stale_after s: the last pose, flagged (sent once on
                    // the transition and in replies)
  kCalibrated = 1,  // placed by the calibration only
  kCorrected = 2,   // drift-corrected by recent global poses (fuser tracking)
  kHolding = 3,     // drift correction held (no global pose for the fuser's hold_after)
};

struct Output {
  std::string address;  // /coloc/users/<id>/head or /coloc/users/<id>/controller/<n>
  PoseMessage pose;     // time = the input's time, per-address sequence, UserState as state
};

// Counters since construction (inputs that were not turned into outputs, by reason).
struct SessionStats {
  std::uint64_t head_poses = 0;        // head poses accepted
  std::uint64_t controller_poses = 0;  // controller poses accepted
  std::uint64_t global_poses = 0;      // global poses handed to a fuser
  std::uint64_t anchor_poses = 0;      // localizer poses of the anchor camera used
  std::uint64_t published = 0;         // outputs produced (before fan-out to targets)
  std::uint64_t unknown_participant = 0;
  std::uint64_t bad_controller = 0;      // controller index out of the participant's range
  std::uint64_t out_of_order = 0;        // older sequence number than the stream's last
  std::uint64_t implausible = 0;         // out of line with the stream (StreamGuard)
  std::uint64_t waiting_for_anchor = 0;  // poses before the anchor camera was localized
  std::uint64_t stale_events = 0;        // transitions to stale (head and controllers)
  std::uint64_t reloads = 0;             // calibrations replaced while running
  std::uint64_t reload_failures = 0;     // new calibration files that could not be used
};

// The outcome of a calibration reload.
struct ReloadReport {
  std::string id;
  bool ok = false;
  std::string error;         // why not, when !ok (the old calibration stays)
  double translation = 0.0;  // m: how far the user's last head pose moved in the world
  double rotation = 0.0;     // rad: and turned
};

// What a participant looks like now (for replies, status and tests).
struct ParticipantSnapshot {
  std::string id;
  ParticipantKind kind = ParticipantKind::kVr;
  SE3 world_from_vr;  // from the calibration (before drift correction)
  SE3 correction;     // the applied drift correction C (identity without global poses)
  std::optional<Output> head;
  std::vector<std::optional<Output>> controllers;
  bool stale = true;
  std::uint64_t calibration_version = 0;  // 0 = as loaded, +1 per reload
};

class Session {
 public:
  // Reads every participant's calibration; throws coloc::Error naming the participant's
  // calibration field and file when one cannot be read.
  explicit Session(SessionConfig config, FuserOptions fuser = {});
  // With the calibrations given (one per participant, in order; simulations). Reloads still
  // read the participants' files.
  Session(SessionConfig config, std::vector<registration::handeye::CalibrationFile> calibrations,
          FuserOptions fuser = {});

  const SessionConfig& config() const { return config_; }
  bool anchored() const { return anchored_; }
  const SE3& world_from_camera() const { return world_from_camera_; }

  // Inputs. `id` names the participant; an unknown id is counted and ignored. Outputs are
  // appended to `out`.
  void push_head(const std::string& id, const PoseMessage& vr_from_head, double now,
                 std::vector<Output>& out);
  void push_controller(const std::string& id, int index, const PoseMessage& vr_from_controller,
                       double now, std::vector<Output>& out);
  // A global pose (world_from_head, e.g. from `coloc localize --cam-from-head` on that user's
  // headset camera) for drift correction.
  void push_global(const std::string& id, const PoseMessage& world_from_head, double now);
  // A localizer pose of the anchor camera (AnchorMode::kLocalize).
  void push_anchor(const PoseMessage& world_from_camera);

  // Marks participants and controllers silent for stale_after as stale (one output each).
  void tick(double now, std::vector<Output>& out);
  // The next `now` at which tick() may have something to do (+infinity: nothing pending).
  double next_deadline() const;
  // Current poses of one participant (or all when id is empty), as outputs with their state.
  // Returns false for an unknown id.
  bool current(const std::string& id, std::vector<Output>& out);

  // Re-reads a participant's calibration file and replaces its calibration (the drift
  // correction restarts: it was relative to the old one). On a bad file the old calibration
  // stays and the report says why.
  ReloadReport reload(const std::string& id);
  // The participant whose calibration file is `path` (for file watchers), or nullptr.
  const ParticipantConfig* participant_by_calibration(const std::filesystem::path& path) const;

  ParticipantSnapshot snapshot(const std::string& id) const;
  const SessionStats& stats() const { return stats_; }
  void count_unknown_participant() { ++stats_.unknown_participant; }

 private:
  struct Track {
    bool have = false;
    bool stale = false;
    double last_seen = 0.0;
    StreamGuard guard;
    Output last;
  };
  struct Participant {
    ParticipantConfig config;
    registration::handeye::CalibrationFile calibration;
    SE3 world_from_vr;
    std::unique_ptr<DriftFuser> fuser;  // only with drift correction
    StreamGuard global_guard;
    Track head;
    std::vector<Track> controllers;
    std::uint64_t version = 0;
  };

  // StreamGuard's verdict on m (arrived at `now`, session clock); false when it is dropped
  // (counted). The verdict stays in last_verdict_ for the caller's resync.
  bool admit(StreamGuard& guard, const PoseMessage& m, double now);
  Participant* find(const std::string& id);
  const Participant* find(const std::string& id) const;
  void place(Participant& p) const;
  UserState state_of(const Participant& p) const;
  SE3 correction_of(const Participant& p) const;
  void emit(Track& track, double time, UserState state, const SE3& world_pose,
            std::vector<Output>& out);

  SessionConfig config_;
  FuserOptions fuser_options_;
  std::vector<Participant> participants_;
  std::map<std::string, std::size_t, std::less<>> index_;
  bool anchored_ = false;
  SE3 world_from_camera_;
  std::vector<SE3> anchor_samples_;
  SessionStats stats_;
  StreamVerdict last_verdict_ = StreamVerdict::kAccepted;
};

// Output addresses.
std::string head_address(std::string_view id);
std::string controller_address(std::string_view id, int index);

}  // namespace coloc::fusion::session
