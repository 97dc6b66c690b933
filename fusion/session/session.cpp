#include "fusion/session/session.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "registration/handeye/compose.hpp"
#include "slam/core/error.hpp"

namespace coloc::fusion::session {

namespace he = registration::handeye;

namespace {

he::CalibrationFile load_calibration(const ParticipantConfig& p, std::size_t index) {
  try {
    return he::read_calibration(p.calibration);
  } catch (const Error& e) {
    throw Error("participant '" + p.id + "': " + format_error(e.message(), e.context()),
                ErrorContext{.file = p.calibration.string(),
                             .field = "participants[" + std::to_string(index) + "].calibration"});
  }
}

}  // namespace

std::string head_address(std::string_view id) {
  return "/coloc/users/" + std::string(id) + "/head";
}

std::string controller_address(std::string_view id, int index) {
  return "/coloc/users/" + std::string(id) + "/controller/" + std::to_string(index);
}

Session::Session(SessionConfig config, FuserOptions fuser)
    : Session(std::move(config), {}, fuser) {}

Session::Session(SessionConfig config, std::vector<he::CalibrationFile> calibrations,
                 FuserOptions fuser)
    : config_(std::move(config)), fuser_options_(fuser) {
  config_.check();
  fuser_options_.check();
  if (!calibrations.empty() && calibrations.size() != config_.participants.size()) {
    throw Error("one calibration per participant is needed", ErrorContext{.field = "calibrations"});
  }
  anchored_ = config_.anchor.mode == AnchorMode::kFixed;
  world_from_camera_ = config_.anchor.world_from_camera;
  participants_.reserve(config_.participants.size());
  for (std::size_t i = 0; i < config_.participants.size(); ++i) {
    Participant p;
    p.config = config_.participants[i];
    p.calibration = calibrations.empty() ? load_calibration(p.config, i) : calibrations[i];
    if (p.config.drift_correction) p.fuser = std::make_unique<DriftFuser>(fuser_options_);
    p.head.last.address = head_address(p.config.id);
    p.controllers.resize(static_cast<std::size_t>(p.config.controllers));
    for (int n = 0; n < p.config.controllers; ++n)
      p.controllers[static_cast<std::size_t>(n)].last.address = controller_address(p.config.id, n);
    place(p);
    index_.emplace(p.config.id, participants_.size());
    participants_.push_back(std::move(p));
  }
}

void Session::place(Participant& p) const {
  p.world_from_vr = world_from_camera_ * p.calibration.vr_from_camera.inverse();
}

Session::Participant* Session::find(const std::string& id) {
  const auto it = index_.find(id);
  return it == index_.end() ? nullptr : &participants_[it->second];
}

const Session::Participant* Session::find(const std::string& id) const {
  const auto it = index_.find(id);
  return it == index_.end() ? nullptr : &participants_[it->second];
}

UserState Session::state_of(const Participant& p) const {
  if (!p.fuser) return UserState::kCalibrated;
  switch (p.fuser->state()) {
    case FusionState::kWaiting:
      return UserState::kCalibrated;
    case FusionState::kTracking:
      return UserState::kCorrected;
    case FusionState::kHolding:
      return UserState::kHolding;
  }
  return UserState::kCalibrated;
}

SE3 Session::correction_of(const Participant& p) const {
  return p.fuser ? p.fuser->applied_drift() : SE3();
}

void Session::emit(Track& track, double time, UserState state, const SE3& world_pose,
                   std::vector<Output>& out) {
  const std::int32_t sequence = track.have ? track.last.pose.sequence + 1 : 0;
  track.last.pose =
      PoseMessage::from_pose(time, sequence, static_cast<std::int32_t>(state), world_pose);
  track.have = true;
  out.push_back(track.last);
  ++stats_.published;
}

bool Session::admit(StreamGuard& guard, const PoseMessage& m, double now) {
  // One stream's plausibility (fusion/stream_guard.hpp): no single message from any peer can
  // freeze a participant's stream, and a restarted sender is taken back.
  last_verdict_ = guard.check(m.sequence, m.time, now);
  if (last_verdict_ == StreamVerdict::kStale) {
    ++stats_.out_of_order;
    return false;
  }
  if (last_verdict_ == StreamVerdict::kImplausible) {
    ++stats_.implausible;
    return false;
  }
  return true;
}

void Session::push_head(const std::string& id, const PoseMessage& vr_from_head, double now,
                        std::vector<Output>& out) {
  Participant* p = find(id);
  if (p == nullptr) {
    ++stats_.unknown_participant;
    return;
  }
  if (!admit(p->head.guard, vr_from_head, now)) return;
  if (last_verdict_ == StreamVerdict::kResynced && p->fuser) p->fuser->restart_xr_clock();
  if (!anchored_) {
    ++stats_.waiting_for_anchor;
    return;
  }
  ++stats_.head_poses;
  const SE3 calibrated = p->world_from_vr * vr_from_head.pose();
  SE3 world_from_head = calibrated;
  if (p->fuser) {
    const std::uint64_t before = p->fuser->stats().out_of_order;
    world_from_head = p->fuser->push_xr_pose(vr_from_head.time, calibrated).world_from_head;
    // A time that does not advance is still a fresh pose of the user: place it as calibrated.
    if (p->fuser->stats().out_of_order != before) world_from_head = correction_of(*p) * calibrated;
  }
  p->head.last_seen = now;
  p->head.stale = false;
  emit(p->head, vr_from_head.time, state_of(*p), world_from_head, out);
}

void Session::push_controller(const std::string& id, int index,
                              const PoseMessage& vr_from_controller, double now,
                              std::vector<Output>& out) {
  Participant* p = find(id);
  if (p == nullptr) {
    ++stats_.unknown_participant;
    return;
  }
  if (index < 0 || index >= static_cast<int>(p->controllers.size())) {
    ++stats_.bad_controller;
    return;
  }
  Track& track = p->controllers[static_cast<std::size_t>(index)];
  if (!admit(track.guard, vr_from_controller, now)) return;
  if (!anchored_) {
    ++stats_.waiting_for_anchor;
    return;
  }
  ++stats_.controller_poses;
  // The drift belongs to the tracking space, so the head's correction applies to its
  // controllers too.
  const SE3 world_from_controller =
      correction_of(*p) * p->world_from_vr * vr_from_controller.pose();
  track.last_seen = now;
  track.stale = false;
  emit(track, vr_from_controller.time, state_of(*p), world_from_controller, out);
}

void Session::push_global(const std::string& id, const PoseMessage& world_from_head, double now) {
  Participant* p = find(id);
  if (p == nullptr) {
    ++stats_.unknown_participant;
    return;
  }
  if (!admit(p->global_guard, world_from_head, now)) return;
  if (last_verdict_ == StreamVerdict::kResynced && p->fuser) p->fuser->restart_global_clock();
  if (!p->fuser) return;  // drift correction off for this participant
  ++stats_.global_poses;
  p->fuser->push_global_pose(world_from_head.time, world_from_head.pose(),
                             tracking_state_from_wire(world_from_head.state));
}

void Session::push_anchor(const PoseMessage& world_from_camera) {
  if (anchored_ || config_.anchor.mode != AnchorMode::kLocalize) return;
  if (world_from_camera.state == 0) return;  // the localizer is lost
  ++stats_.anchor_poses;
  anchor_samples_.push_back(world_from_camera.pose());
  if (static_cast<int>(anchor_samples_.size()) < config_.anchor.localize_poses) return;
  world_from_camera_ = registration::handeye::chordal_mean(anchor_samples_);
  const registration::handeye::Dispersion d = registration::handeye::dispersion(anchor_samples_);
  anchored_ = true;
  for (Participant& p : participants_)
    place(p);
  spdlog::info(
      "session: anchor camera '{}' localized from {} poses (spread {:.1f} mm rms, {:.2f} "
      "deg rms); participants are placed from now on",
      config_.anchor.camera, anchor_samples_.size(), d.translation_rms * 1e3,
      d.rotation_rms * 180.0 / M_PI);
}

void Session::tick(double now, std::vector<Output>& out) {
  const auto check = [&](Track& t) {
    if (!t.have || t.stale || now - t.last_seen < config_.stale_after) return;
    t.stale = true;
    ++stats_.stale_events;
    // Flag the last pose instead of freezing it silently: renderers can grey the user out.
    emit(t, t.last.pose.time, UserState::kStale, t.last.pose.pose(), out);
    spdlog::info("session: {} is stale (nothing for {:.2f} s)", t.last.address, now - t.last_seen);
  };
  for (Participant& p : participants_) {
    check(p.head);
    for (Track& t : p.controllers)
      check(t);
  }
}

double Session::next_deadline() const {
  double next = std::numeric_limits<double>::infinity();
  for (const Participant& p : participants_) {
    if (p.head.have && !p.head.stale) next = std::min(next, p.head.last_seen + config_.stale_after);
    for (const Track& t : p.controllers) {
      if (t.have && !t.stale) next = std::min(next, t.last_seen + config_.stale_after);
    }
  }
  return next;
}

bool Session::current(const std::string& id, std::vector<Output>& out) {
  if (!id.empty() && find(id) == nullptr) {
    ++stats_.unknown_participant;
    return false;
  }
  for (const Participant& p : participants_) {
    if (!id.empty() && p.config.id != id) continue;
    if (p.head.have) out.push_back(p.head.last);
    for (const Track& t : p.controllers) {
      if (t.have) out.push_back(t.last);
    }
  }
  return true;
}

ReloadReport Session::reload(const std::string& id) {
  ReloadReport report;
  report.id = id;
  Participant* p = find(id);
  if (p == nullptr) {
    report.error = "unknown participant";
    ++stats_.reload_failures;
    return report;
  }
  try {
    p->calibration = registration::handeye::read_calibration(p->config.calibration);
  } catch (const Error& e) {
    report.error = format_error(e.message(), e.context());
    ++stats_.reload_failures;
    spdlog::error("session: participant '{}': new calibration not used ({}); keeping the old one",
                  id, report.error);
    return report;
  }
  const SE3 before = p->world_from_vr;
  place(*p);
  // Where the user would jump: their last head pose through the old and the new placement.
  const SE3 vr_from_head =
      p->head.have ? before.inverse() * correction_of(*p).inverse() * p->head.last.pose.pose()
                   : SE3();
  const SE3 old_head = before * vr_from_head;
  const SE3 new_head = p->world_from_vr * vr_from_head;
  report.translation = translation_distance(old_head, new_head);
  report.rotation = rotation_distance(old_head, new_head);
  if (p->fuser) p->fuser = std::make_unique<DriftFuser>(fuser_options_);
  ++p->version;
  ++stats_.reloads;
  report.ok = true;
  spdlog::info(
      "session: participant '{}' re-anchored from {} (calibration {}): head moves {:.1f} "
      "mm, {:.2f} deg; drift correction restarts",
      id, p->config.calibration.string(), p->version, report.translation * 1e3,
      report.rotation * 180.0 / M_PI);
  return report;
}

const ParticipantConfig* Session::participant_by_calibration(
    const std::filesystem::path& path) const {
  const std::filesystem::path wanted = path.lexically_normal();
  for (const Participant& p : participants_) {
    if (p.config.calibration.lexically_normal() == wanted) return &p.config;
  }
  return nullptr;
}

ParticipantSnapshot Session::snapshot(const std::string& id) const {
  const Participant* p = find(id);
  if (p == nullptr) throw Error("unknown participant '" + id + "'", ErrorContext{.field = "id"});
  ParticipantSnapshot s;
  s.id = id;
  s.kind = p->config.kind;
  s.world_from_vr = p->world_from_vr;
  s.correction = correction_of(*p);
  if (p->head.have) s.head = p->head.last;
  for (const Track& t : p->controllers)
    s.controllers.push_back(t.have ? std::optional<Output>(t.last) : std::nullopt);
  s.stale = !p->head.have || p->head.stale;
  s.calibration_version = p->version;
  return s;
}

}  // namespace coloc::fusion::session
