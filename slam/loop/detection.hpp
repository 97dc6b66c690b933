#pragma once
// Loop candidates (ORB-SLAM's LoopClosing::DetectLoop): the keyframe BoW database is queried
// with the new keyframe's BoW vector; keyframes covisible with it are excluded (they are its
// neighbourhood, not a loop), and so is every keyframe scoring below the worst score of that
// neighbourhood. The database groups candidates over their covisible keyframes. A candidate
// group is kept only when the groups of `min_consistency` consecutive keyframes overlap it: one
// keyframe that happens to look like an old place is not enough, a walk through it is.
//
// Threads: the detector is the loop closer's; detect() needs the map lock.
#include <set>
#include <vector>

#include "slam/bow/database.hpp"
#include "slam/loop/loop_options.hpp"
#include "slam/map/map.hpp"

namespace coloc::slam::loop {

struct LoopCandidate {
  KeyframeId keyframe;
  double score = 0.0;        // BoW L1 score against the query keyframe
  double group_score = 0.0;  // accumulated over its covisible group
  int consistency = 0;       // consecutive keyframes whose candidate groups overlapped
};

struct Detection {
  std::vector<LoopCandidate> consistent;  // candidates that passed the consistency test
  std::size_t raw_candidates = 0;         // what the database returned
  double min_score = 0.0;                 // the neighbourhood's lowest BoW score
};

class LoopDetector {
 public:
  explicit LoopDetector(const LoopOptions& options) : options_(options) {}
  // For the keyframe `current` (in the map and in the database, with its BoW vector).
  Detection detect(const map::Map& map, const bow::BowDatabase& database, KeyframeId current);
  // Forgets the consistency history (after a correction: the groups were of the old map).
  void reset() { groups_.clear(); }

 private:
  struct Group {
    std::set<KeyframeId> members;
    int consistency = 0;
  };
  // Updates groups_ with this keyframe's candidates; returns those consistent enough.
  std::vector<LoopCandidate> consistency(const map::Map& map,
                                         const std::vector<LoopCandidate>& candidates);

  LoopOptions options_;
  std::vector<Group> groups_;  // the previous keyframe's candidate groups
};

}  // namespace coloc::slam::loop
