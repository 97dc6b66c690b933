#include "slam/map/map.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "slam/core/error.hpp"

namespace coloc::slam::map {

int MapPoint::predict_level(double distance, const frame::FrameGeometry& g) const {
  if (distance <= 0.0 || g.log_scale_factor <= 0.0) return 0;
  const int level =
      static_cast<int>(std::ceil(std::log(max_distance / distance) / g.log_scale_factor));
  return std::clamp(level, 0, g.levels() - 1);
}

Keyframe& Map::add_keyframe(Keyframe keyframe) {
  const KeyframeId id = keyframe.id;
  if (!id.valid() || keyframes_.count(id))
    throw Error("Map::add_keyframe: invalid or duplicate id");
  if (!first_keyframe_.valid()) first_keyframe_ = id;
  Keyframe& kf = keyframes_.emplace(id, std::move(keyframe)).first->second;
  for (std::size_t i = 0; i < kf.frame.points.size(); ++i) {
    const MapPointId p = kf.frame.points[i];
    if (!p.valid()) continue;
    auto it = points_.find(p);
    if (it == points_.end()) {
      kf.frame.points[i] = MapPointId::invalid();
      continue;
    }
    if (it->second.observations.count(id)) {  // two keypoints of one keyframe: keep the first
      kf.frame.points[i] = MapPointId::invalid();
      continue;
    }
    it->second.observations[id] = static_cast<std::uint32_t>(i);
  }
  return kf;
}

MapPoint& Map::add_point(const Eigen::Vector3d& position, KeyframeId keyframe,
                         std::uint32_t index) {
  Keyframe& kf = keyframes_.at(keyframe);
  MapPoint p;
  p.id = point_ids_.next();
  p.position = position;
  p.reference = keyframe;
  p.first_keyframe = keyframe;
  p.observations[keyframe] = index;
  kf.frame.points[index] = p.id;
  MapPoint& stored = points_.emplace(p.id, std::move(p)).first->second;
  update_point(stored.id);
  return stored;
}

void Map::add_observation(MapPointId point, KeyframeId keyframe, std::uint32_t index) {
  MapPoint& p = points_.at(point);
  Keyframe& kf = keyframes_.at(keyframe);
  if (p.observations.count(keyframe)) return;
  if (kf.frame.points[index].valid()) erase_observation(kf.frame.points[index], keyframe);
  p.observations[keyframe] = index;
  kf.frame.points[index] = point;
}

void Map::erase_observation(MapPointId point, KeyframeId keyframe) {
  auto it = points_.find(point);
  if (it == points_.end()) return;
  auto obs = it->second.observations.find(keyframe);
  if (obs == it->second.observations.end()) return;
  auto kf = keyframes_.find(keyframe);
  if (kf != keyframes_.end()) kf->second.frame.points[obs->second] = MapPointId::invalid();
  it->second.observations.erase(obs);
  if (it->second.observations.size() <= 1) {
    // ORB-SLAM drops points seen by fewer than two keyframes once they lose an observation.
    erase_point(point);
    return;
  }
  if (it->second.reference == keyframe)
    it->second.reference = it->second.observations.begin()->first;
}

void Map::erase_point(MapPointId point) {
  auto it = points_.find(point);
  if (it == points_.end()) return;
  for (const auto& [kf_id, index] : it->second.observations) {
    auto kf = keyframes_.find(kf_id);
    if (kf != keyframes_.end() && kf->second.frame.points[index] == point) {
      kf->second.frame.points[index] = MapPointId::invalid();
    }
  }
  points_.erase(it);
}

void Map::replace_point(MapPointId from, MapPointId to) {
  if (from == to) return;
  auto a = points_.find(from);
  auto b = points_.find(to);
  if (a == points_.end() || b == points_.end()) return;
  if (a->second.observations.size() > b->second.observations.size()) {
    std::swap(from, to);
    std::swap(a, b);
  }
  MapPoint& target = b->second;
  for (const auto& [kf_id, index] : a->second.observations) {
    Keyframe& kf = keyframes_.at(kf_id);
    if (!target.observations.count(kf_id)) {
      target.observations[kf_id] = index;
      kf.frame.points[index] = to;
    } else {
      kf.frame.points[index] = MapPointId::invalid();
    }
  }
  target.visible += a->second.visible;
  target.found += a->second.found;
  points_.erase(a);
  update_point(to);
}

void Map::erase_keyframe(KeyframeId keyframe) {
  auto it = keyframes_.find(keyframe);
  if (it == keyframes_.end() || keyframe == first_keyframe_) return;
  Keyframe& kf = it->second;
  // Every keyframe, not only kf's neighbours: edges can be one-sided (update_connections drops
  // a stale edge only on the side it recomputes), and none may outlive the keyframe.
  for (auto& [other_id, other] : keyframes_) {
    if (other_id == keyframe) continue;
    other.covisibility.erase(keyframe);
    auto& ord = other.covisible_ordered;
    ord.erase(std::remove(ord.begin(), ord.end(), keyframe), ord.end());
    // The gyro measured the whole way from `other` through kf: the link skips kf instead.
    if (other.gyro && other.gyro->next == keyframe) {
      if (kf.gyro) {
        other.gyro = chain(*other.gyro, *kf.gyro);
      } else {
        other.gyro.reset();
      }
    }
  }
  for (std::size_t i = 0; i < kf.frame.points.size(); ++i) {
    if (kf.frame.points[i].valid()) erase_observation(kf.frame.points[i], keyframe);
  }
  // Children pick the covisible keyframe they share most points with among the keyframes older
  // than themselves (already in the tree, so no cycle can form), else kf's parent; ORB-SLAM's
  // rule, simplified to one pass.
  // A keyframe never connected has no parent: the root stands in, so that its children and
  // the frames referencing it stay attached to the map.
  const KeyframeId parent = keyframes_.count(kf.parent) ? kf.parent : first_keyframe_;
  for (KeyframeId child : kf.children) {
    auto c = keyframes_.find(child);
    if (c == keyframes_.end()) continue;
    KeyframeId best = parent;
    int best_w = -1;
    for (const auto& [cand, w] : c->second.covisibility) {
      if (cand != keyframe && keyframes_.count(cand) && cand < child && w > best_w) {
        best = cand;
        best_w = w;
      }
    }
    c->second.parent = best;
    if (keyframes_.count(best)) keyframes_.at(best).children.insert(child);
  }
  // A loop edge is a constraint the essential graph must keep: the parent (rigidly tied to kf
  // by the spanning tree) takes it over, unless that would be a self-edge.
  for (KeyframeId partner : kf.loop_edges) {
    auto p = keyframes_.find(partner);
    if (p == keyframes_.end()) continue;
    p->second.loop_edges.erase(keyframe);
    if (partner != parent && keyframes_.count(parent)) {
      p->second.loop_edges.insert(parent);
      keyframes_.at(parent).loop_edges.insert(partner);
    }
  }
  if (keyframes_.count(parent)) {
    keyframes_.at(parent).children.erase(keyframe);
    erased_[keyframe] = {parent,
                         kf.cam_from_world() * keyframes_.at(parent).cam_from_world().inverse()};
  }
  keyframes_.erase(it);
}

namespace {

// covisible_ordered from covisibility: decreasing weight, then increasing id (deterministic).
void order_covisible(Keyframe& kf) {
  std::vector<std::pair<int, KeyframeId>> ord;
  for (const auto& [k, w] : kf.covisibility)
    ord.emplace_back(w, k);
  std::sort(ord.begin(), ord.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second < b.second;
  });
  kf.covisible_ordered.clear();
  for (const auto& e : ord)
    kf.covisible_ordered.push_back(e.second);
}

}  // namespace

void Map::update_connections(KeyframeId keyframe) {
  Keyframe& kf = keyframes_.at(keyframe);
  std::map<KeyframeId, int> counts;
  for (MapPointId p : kf.frame.points) {
    if (!p.valid()) continue;
    auto it = points_.find(p);
    if (it == points_.end()) continue;
    for (const auto& [other, idx] : it->second.observations) {
      if (other != keyframe && keyframes_.count(other)) ++counts[other];
    }
  }
  constexpr int kMinWeight = 15;
  KeyframeId best, best_older;
  int best_w = 0, best_older_w = 0;
  std::map<KeyframeId, int> kept;
  for (const auto& [other, w] : counts) {
    if (w > best_w) {
      best_w = w;
      best = other;
    }
    // The spanning-tree parent is an older keyframe: tracking may already have inserted newer
    // ones that share points, and a parent among them could close a cycle.
    if (other < keyframe && w > best_older_w) {
      best_older_w = w;
      best_older = other;
    }
    if (w >= kMinWeight) kept[other] = w;
  }
  if (kept.empty() && best.valid()) kept[best] = best_w;
  // Edges are symmetric: a neighbour this keyframe no longer shares enough points with drops
  // its side too.
  for (const auto& [other, w] : kf.covisibility) {
    if (kept.count(other)) continue;
    auto o = keyframes_.find(other);
    if (o == keyframes_.end()) continue;
    o->second.covisibility.erase(keyframe);
    order_covisible(o->second);
  }
  kf.covisibility = kept;
  order_covisible(kf);
  for (const auto& [other, w] : kept) {
    Keyframe& o = keyframes_.at(other);
    o.covisibility[keyframe] = w;
    order_covisible(o);
  }
  if (!kf.parent.valid() && keyframe != first_keyframe_ && best_older.valid()) {
    kf.parent = best_older;
    keyframes_.at(kf.parent).children.insert(keyframe);
  }
}

void Map::update_point(MapPointId point) {
  MapPoint& p = points_.at(point);
  std::vector<const features::Descriptor*> descs;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  int n = 0;
  for (const auto& [kf_id, idx] : p.observations) {
    const Keyframe& kf = keyframes_.at(kf_id);
    descs.push_back(&kf.frame.features.descriptors[idx]);
    normal += (p.position - kf.camera_centre()).normalized();
    ++n;
  }
  if (n == 0) return;
  p.normal = normal.normalized();
  const Keyframe& ref = keyframes_.at(
      p.observations.count(p.reference) ? p.reference : p.observations.begin()->first);
  const std::uint32_t ref_idx = p.observations.at(ref.id);
  const double dist = (p.position - ref.camera_centre()).norm();
  const int level = ref.frame.level(ref_idx);
  const auto& g = ref.frame.geometry();
  p.max_distance = dist * g.scale_factors[static_cast<std::size_t>(level)];
  p.min_distance = p.max_distance / g.scale_factors.back();
  // Most representative descriptor: least median Hamming distance to the other observations.
  const std::size_t m = descs.size();
  int best_median = 1 << 30;
  std::vector<int> row(m);
  for (std::size_t i = 0; i < m; ++i) {
    for (std::size_t j = 0; j < m; ++j)
      row[j] = features::hamming_distance(*descs[i], *descs[j]);
    std::nth_element(row.begin(), row.begin() + static_cast<long>((m - 1) / 2), row.end());
    const int med = row[(m - 1) / 2];
    if (med < best_median) {
      best_median = med;
      p.descriptor = *descs[i];
    }
  }
}

int Map::weighted_observations(MapPointId point) const {
  const MapPoint* p = this->point(point);
  if (!p) return 0;
  int n = 0;
  for (const auto& [kf_id, idx] : p->observations) {
    const Keyframe* kf = keyframe(kf_id);
    n += (kf && kf->frame.u_right[idx] >= 0.0f) ? 2 : 1;
  }
  return n;
}

std::vector<KeyframeId> Map::covisible(KeyframeId keyframe, std::size_t n) const {
  const Keyframe* kf = this->keyframe(keyframe);
  if (!kf) return {};
  std::vector<KeyframeId> out;
  for (KeyframeId k : kf->covisible_ordered) {
    if (n && out.size() >= n) break;
    if (keyframes_.count(k)) out.push_back(k);
  }
  return out;
}

Keyframe* Map::keyframe(KeyframeId id) {
  auto it = keyframes_.find(id);
  return it == keyframes_.end() ? nullptr : &it->second;
}
const Keyframe* Map::keyframe(KeyframeId id) const {
  auto it = keyframes_.find(id);
  return it == keyframes_.end() ? nullptr : &it->second;
}
MapPoint* Map::point(MapPointId id) {
  auto it = points_.find(id);
  return it == points_.end() ? nullptr : &it->second;
}
const MapPoint* Map::point(MapPointId id) const {
  auto it = points_.find(id);
  return it == points_.end() ? nullptr : &it->second;
}

std::optional<SE3> Map::keyframe_pose(KeyframeId id) const {
  SE3 cam_from_kf;  // accumulated relative transform
  for (int hops = 0; hops < 100000; ++hops) {
    if (const Keyframe* kf = keyframe(id)) return cam_from_kf * kf->cam_from_world();
    auto it = erased_.find(id);
    if (it == erased_.end()) return std::nullopt;
    cam_from_kf = cam_from_kf * it->second.cam_from_parent;
    id = it->second.parent;
  }
  return std::nullopt;
}

MapBookkeeping Map::bookkeeping() const {
  return {first_keyframe_, keyframe_ids_.peek(), point_ids_.peek(), erased_};
}

namespace {

std::string id_text(std::uint64_t v) {
  return std::to_string(v);
}

}  // namespace

Map Map::restore(std::unordered_map<KeyframeId, Keyframe> keyframes,
                 std::unordered_map<MapPointId, MapPoint> points, MapBookkeeping bookkeeping) {
  Map m;
  m.keyframes_ = std::move(keyframes);
  m.points_ = std::move(points);
  m.erased_ = std::move(bookkeeping.erased);
  m.first_keyframe_ = bookkeeping.first_keyframe;
  if (bookkeeping.next_keyframe_id > 0)
    m.keyframe_ids_.continue_after(KeyframeId(bookkeeping.next_keyframe_id - 1));
  if (bookkeeping.next_point_id > 0)
    m.point_ids_.continue_after(MapPointId(bookkeeping.next_point_id - 1));
  for (const auto& [id, kf] : m.keyframes_) {
    if (kf.id != id || id.value() >= bookkeeping.next_keyframe_id)
      throw Error("Map::restore: keyframe id " + id_text(id.value()) +
                  " is not below the next keyframe id " + id_text(bookkeeping.next_keyframe_id));
  }
  for (const auto& [id, p] : m.points_) {
    if (p.id != id || id.value() >= bookkeeping.next_point_id)
      throw Error("Map::restore: point id " + id_text(id.value()) +
                  " is not below the next point id " + id_text(bookkeeping.next_point_id));
  }
  m.check_restored_observations();
  m.check_restored_tree();
  for (auto& [id, kf] : m.keyframes_) {
    kf.children.clear();
    order_covisible(kf);
  }
  for (const auto& [id, kf] : m.keyframes_) {
    if (kf.parent.valid()) m.keyframes_.at(kf.parent).children.insert(id);
  }
  return m;
}

void Map::check_restored_observations() const {
  for (const auto& [pid, p] : points_) {
    for (const auto& [k, idx] : p.observations) {
      const Keyframe* kf = keyframe(k);
      if (!kf || idx >= kf->frame.points.size() || kf->frame.points[idx] != pid)
        throw Error("Map::restore: point " + id_text(pid.value()) + " observed by keyframe " +
                    id_text(k.value()) + " at keypoint " + id_text(idx) +
                    ", which does not hold it");
    }
  }
  for (const auto& [k, kf] : keyframes_) {
    for (std::size_t i = 0; i < kf.frame.points.size(); ++i) {
      const MapPointId pid = kf.frame.points[i];
      if (!pid.valid()) continue;
      const MapPoint* p = point(pid);
      const auto o = p ? p->observations.find(k) : Observations::const_iterator{};
      if (!p || o == p->observations.end() || o->second != i)
        throw Error("Map::restore: keyframe " + id_text(k.value()) + " keypoint " + id_text(i) +
                    " holds point " + id_text(pid.value()) + " without its observation");
    }
    for (const auto& [other, w] : kf.covisibility) {
      if (other == k || !keyframes_.count(other))
        throw Error("Map::restore: keyframe " + id_text(k.value()) +
                    " has a covisibility edge to missing keyframe " + id_text(other.value()));
    }
    if (kf.gyro && (kf.gyro->next == k || !keyframes_.count(kf.gyro->next)))
      throw Error("Map::restore: keyframe " + id_text(k.value()) +
                  " has a gyro link to missing keyframe " + id_text(kf.gyro->next.value()));
  }
}

void Map::check_restored_tree() const {
  if (!keyframes_.empty() && !keyframes_.count(first_keyframe_))
    throw Error("Map::restore: the first keyframe " + id_text(first_keyframe_.value()) +
                " is not in the map");
  for (const auto& [k, kf] : keyframes_) {
    if (!kf.parent.valid()) continue;
    if (k == first_keyframe_ || kf.parent == k || !keyframes_.count(kf.parent))
      throw Error("Map::restore: keyframe " + id_text(k.value()) + " has an invalid parent " +
                  id_text(kf.parent.value()));
  }
  // Walking up from every keyframe must end (at the root or at a keyframe not yet connected);
  // `done` remembers keyframes known to end, so the whole check is linear.
  std::unordered_map<KeyframeId, bool> done;
  for (const auto& [k, kf] : keyframes_) {
    std::vector<KeyframeId> path;
    KeyframeId up = k;
    while (up.valid() && !done.count(up)) {
      if (path.size() > keyframes_.size())
        throw Error("Map::restore: spanning-tree cycle through keyframe " + id_text(k.value()));
      path.push_back(up);
      up = keyframes_.at(up).parent;
    }
    for (KeyframeId p : path)
      done[p] = true;
  }
  for (const auto& [k, e] : erased_) {
    if (keyframes_.count(k) || !(keyframes_.count(e.parent) || erased_.count(e.parent)))
      throw Error("Map::restore: erased keyframe " + id_text(k.value()) +
                  " is present or chains to missing keyframe " + id_text(e.parent.value()));
  }
}

}  // namespace coloc::slam::map
