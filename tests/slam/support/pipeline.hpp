#pragma once
// Tracking and local mapping wired by hand over one shared map (what System does, opened up so
// tests can put their own keyframe sinks in between), and a sink that records what reaches it.
#include <atomic>
#include <memory>
#include <mutex>
#include <vector>

#include "slam/features/orb_extractor.hpp"
#include "slam/frame/frame.hpp"
#include "slam/map/keyframe_sink.hpp"
#include "slam/settings/settings.hpp"

namespace coloc::slam::test_support {

// What a Tracker needs from the settings besides the map and the vocabulary.
struct TrackerInputs {
  std::shared_ptr<const frame::FrameGeometry> geometry;
  features::ExtractorOptions extractor;
  Camera camera;
};

inline TrackerInputs tracker_inputs(const settings::Settings& s) {
  TrackerInputs in;
  in.extractor = {s.orb.n_features, s.orb.scale_factor, s.orb.n_levels, s.orb.ini_th_fast,
                  s.orb.min_th_fast};
  in.camera = s.camera;
  const features::OrbExtractor probe(in.extractor);
  in.geometry = std::make_shared<frame::FrameGeometry>(frame::FrameGeometry::make(
      s.camera, s.depth->bf, s.depth->close_depth, probe.scale_factors()));
  return in;
}

// Records the keyframe ids pushed to it and counts the waits and interrupts; `accept` says what
// accepting() answers, `busy` what idle() does not.
class RecordingSink final : public map::KeyframeSink {
 public:
  bool push(map::KeyframeMessage message) override {
    std::lock_guard lock(mutex_);
    ids_.push_back(message.id);
    return true;
  }
  bool idle() const override { return !busy; }
  std::size_t queued() const override { return 0; }
  bool accepting() const override { return accept; }
  void interrupt() override { ++interrupts; }
  void wait_idle() override { ++waits; }
  std::vector<KeyframeId> ids() const {
    std::lock_guard lock(mutex_);
    return ids_;
  }
  bool accept = true;
  bool busy = false;               // what idle() denies: a mapper always at work, its queue empty
  std::atomic<int> waits{0};       // wait_idle() calls
  std::atomic<int> interrupts{0};  // interrupt() calls

 private:
  mutable std::mutex mutex_;
  std::vector<KeyframeId> ids_;
};

}  // namespace coloc::slam::test_support
