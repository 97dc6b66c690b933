#include "slam/loop/detection.hpp"

#include <algorithm>

namespace coloc::slam::loop {

Detection LoopDetector::detect(const map::Map& map, const bow::BowDatabase& database,
                               KeyframeId current) {
  Detection out;
  const map::Keyframe* kf = map.keyframe(current);
  if (!kf || kf->frame.bow.empty()) {
    groups_.clear();
    return out;
  }
  // The neighbourhood's worst score is the bar: an old place must look at least as similar as
  // the keyframes we know share the view.
  const std::vector<KeyframeId> neighbours = map.covisible(current);
  double min_score = 1.0;
  for (KeyframeId n : neighbours) {
    const map::Keyframe* other = map.keyframe(n);
    if (other && !other->frame.bow.empty())
      min_score = std::min(min_score, bow::score_l1(kf->frame.bow, other->frame.bow));
  }
  if (neighbours.empty()) min_score = 0.0;
  out.min_score = min_score;
  const std::set<KeyframeId> excluded(neighbours.begin(), neighbours.end());

  bow::QueryOptions query;
  query.max_results = options_.max_candidates;
  query.min_score = min_score;
  query.accept = [&](bow::ImageKey key) {
    const KeyframeId id(key);
    return id != current && !excluded.count(id) && map.keyframe(id) != nullptr;
  };
  query.neighbours = [&](bow::ImageKey key) {
    std::vector<bow::ImageKey> keys;
    for (KeyframeId n : map.covisible(KeyframeId(key), options_.group_neighbours))
      keys.push_back(n.value());
    return keys;
  };
  std::vector<LoopCandidate> candidates;
  for (const bow::QueryResult& r : database.query(kf->frame.bow, query))
    candidates.push_back({KeyframeId(r.image), r.score, r.group_score, 0});
  out.raw_candidates = candidates.size();
  out.consistent = consistency(map, candidates);
  return out;
}

std::vector<LoopCandidate> LoopDetector::consistency(const map::Map& map,
                                                     const std::vector<LoopCandidate>& candidates) {
  std::vector<Group> next;
  std::vector<bool> continued(groups_.size(), false);
  std::vector<LoopCandidate> enough;
  for (LoopCandidate c : candidates) {
    Group group;
    group.members.insert(c.keyframe);
    for (KeyframeId n : map.covisible(c.keyframe))
      group.members.insert(n);
    bool any = false;
    bool reported = false;
    for (std::size_t i = 0; i < groups_.size(); ++i) {
      const auto& prev = groups_[i].members;
      const bool overlaps = std::any_of(group.members.begin(), group.members.end(),
                                        [&](KeyframeId k) { return prev.count(k) > 0; });
      if (!overlaps) continue;
      any = true;
      const int consistency = groups_[i].consistency + 1;
      if (!continued[i]) {
        next.push_back({group.members, consistency});
        continued[i] = true;
      }
      if (consistency >= options_.min_consistency && !reported) {
        c.consistency = consistency;
        enough.push_back(c);
        reported = true;
      }
    }
    if (!any) next.push_back({group.members, 0});
  }
  groups_ = std::move(next);
  return enough;
}

}  // namespace coloc::slam::loop
