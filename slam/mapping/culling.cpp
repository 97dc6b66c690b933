// Keyframe culling: ORB-SLAM's redundancy test, a lower share on straight stretches
// (LocalMappingOptions::redundancy_straight says why), and markers' last views kept.
#include "slam/mapping/culling.hpp"

#include <algorithm>
#include <cmath>

#include "slam/mapping/local_mapper.hpp"

namespace coloc::slam::mapping {

double redundant_share(const map::Map& m, KeyframeId k) {
  const map::Keyframe* kf = m.keyframe(k);
  if (!kf) return 0.0;
  const frame::Frame& f = kf->frame;
  int total = 0;
  int redundant = 0;
  for (std::size_t i = 0; i < f.size(); ++i) {
    const map::MapPoint* p = f.points[i].valid() ? m.point(f.points[i]) : nullptr;
    // RGB-D: only close points count (far ones are weakly constrained anyway).
    if (!p || !f.is_close(i)) continue;
    ++total;
    if (m.weighted_observations(p->id) <= 3) continue;
    int seen = 0;
    for (const auto& [ok, oidx] : p->observations) {
      if (ok == k) continue;
      const map::Keyframe* other = m.keyframe(ok);
      if (other && other->frame.level(oidx) <= f.level(i) + 1 && ++seen >= 3) break;
    }
    redundant += seen >= 3 ? 1 : 0;
  }
  return total > 0 ? static_cast<double>(redundant) / total : 0.0;
}

double axis_angle_deg(const map::Keyframe& a, const map::Keyframe& b) {
  const Eigen::Vector3d za = a.cam_from_world().so3().inverse() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d zb = b.cam_from_world().so3().inverse() * Eigen::Vector3d::UnitZ();
  return std::acos(std::clamp(za.dot(zb), -1.0, 1.0)) * 180.0 / M_PI;
}

bool between_same_view(const map::Map& m, KeyframeId k, double max_deg) {
  const map::Keyframe* kf = m.keyframe(k);
  if (!kf) return false;
  KeyframeId before;
  KeyframeId after;
  for (KeyframeId o : m.covisible(k)) {
    if (o < k && (!before.valid() || before < o)) before = o;
    if (k < o && (!after.valid() || o < after)) after = o;
  }
  if (!before.valid() || !after.valid()) return false;
  return axis_angle_deg(*kf, *m.keyframe(before)) < max_deg &&
         axis_angle_deg(*kf, *m.keyframe(after)) < max_deg;
}

bool markers_seen_elsewhere(const map::Map& m, KeyframeId k, int min_others) {
  const map::Keyframe* kf = m.keyframe(k);
  if (!kf) return false;
  for (const markers::MarkerObservation& seen : kf->markers) {
    int others = 0;
    for (const auto& [id, other] : m.keyframes()) {
      if (id == k) continue;
      others += static_cast<int>(
          std::count_if(other.markers.begin(), other.markers.end(),
                        [&](const markers::MarkerObservation& o) { return o.id == seen.id; }));
    }
    if (others < min_others) return false;
  }
  return true;
}

void LocalMapper::cull_keyframes(KeyframeId current) {
  std::lock_guard lock(shared_.mutex);
  map::Map& m = shared_.map;
  if (!m.keyframe(current)) return;
  int culled = 0;
  for (KeyframeId k : m.covisible(current)) {
    // Keyframes newer than `current` are still queued for this thread (tracking inserted them
    // already): not connected, not in the database yet, so not judged yet either.
    if (!m.keyframe(k) || k == m.first_keyframe() || current < k) continue;
    const bool straight = options_.redundancy_straight < options_.redundancy &&
                          between_same_view(m, k, options_.straight_turn_deg);
    const double limit = straight ? options_.redundancy_straight : options_.redundancy;
    if (redundant_share(m, k) > limit && markers_seen_elsewhere(m, k)) {
      shared_.database.erase(k.value());
      m.erase_keyframe(k);
      ++culled;
    }
  }
  std::lock_guard slock(state_mutex_);
  stats_.keyframes_culled += culled;
}

}  // namespace coloc::slam::mapping
