#pragma once
// The map as the two SLAM threads share it: the Map, the keyframe BoW database, and the ONE
// mutex that guards both. Rule: tracking (caller's thread) and local mapping (its own thread)
// hold `mutex` for every read or write of `map` or `database`; long computations (feature
// extraction, bundle adjustment, marker detection) run on copies without the lock.
#include <atomic>
#include <mutex>

#include "slam/bow/database.hpp"
#include "slam/map/map.hpp"

namespace coloc::slam::map {

struct SharedMap {
  std::mutex mutex;
  Map map;
  bow::BowDatabase database;  // image key = keyframe id value
  // The colour camera's rolling-shutter readout (seconds) when the settings do not give it:
  // local mapping estimates it with its bundle adjustment, tracking compensates new frames with
  // it. Set before the threads start; `readout` changes only under `mutex`, together with the
  // keyframes' compensation, and is read without it.
  bool estimate_readout = false;
  std::atomic<double> readout{0.0};
};

}  // namespace coloc::slam::map
