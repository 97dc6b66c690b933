#pragma once
// The keyframes observing a map point, each with the keypoint index it has there: a flat vector
// of (keyframe, keypoint) pairs kept sorted by keyframe id, with the subset of std::map's
// interface the map's users need. A site map holds some 640,000 observations: as std::map
// nodes they took ~64 bytes each (48 requested plus malloc's header), here 16 in one allocation
// per point. Iteration is in ascending keyframe id, as std::map's, so every computation that
// walks a point's observations (descriptor choice, covisibility, BA problems) sees the same
// order as before. A point has a few observations (4.4 on average at the site, at most ~100):
// the linear shifts of an insert or erase in the middle cost less than a node allocation.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <utility>
#include <vector>

#include "slam/core/ids.hpp"

namespace coloc::slam::map {

class Observations {
 public:
  using value_type = std::pair<KeyframeId, std::uint32_t>;  // keyframe, keypoint index
  // Read-only iteration: the keys must stay sorted, and a keypoint index changes through
  // operator[] or insert_or_assign.
  using const_iterator = std::vector<value_type>::const_iterator;
  using iterator = const_iterator;

  const_iterator begin() const { return entries_.begin(); }
  const_iterator end() const { return entries_.end(); }
  std::size_t size() const { return entries_.size(); }
  bool empty() const { return entries_.empty(); }

  const_iterator find(KeyframeId keyframe) const {
    const auto it = lower_bound(keyframe);
    return it != entries_.end() && it->first == keyframe ? const_iterator(it) : end();
  }
  std::size_t count(KeyframeId keyframe) const { return find(keyframe) != end() ? 1 : 0; }
  bool contains(KeyframeId keyframe) const { return find(keyframe) != end(); }
  // Throws std::out_of_range when the keyframe does not observe the point, as std::map::at.
  std::uint32_t at(KeyframeId keyframe) const;

  // The keypoint index of `keyframe`, inserted as 0 when absent (std::map::operator[]).
  std::uint32_t& operator[](KeyframeId keyframe) {
    auto it = lower_bound(keyframe);
    if (it == entries_.end() || it->first != keyframe) it = entries_.insert(it, {keyframe, 0});
    return it->second;
  }
  // Inserts when absent; false (and nothing changes) when the keyframe is already there.
  std::pair<const_iterator, bool> emplace(KeyframeId keyframe, std::uint32_t index) {
    auto it = lower_bound(keyframe);
    if (it != entries_.end() && it->first == keyframe) return {it, false};
    return {entries_.insert(it, {keyframe, index}), true};
  }
  const_iterator erase(const_iterator it) { return entries_.erase(it); }
  std::size_t erase(KeyframeId keyframe) {
    const auto it = find(keyframe);
    if (it == end()) return 0;
    entries_.erase(it);
    return 1;
  }
  void clear() { entries_.clear(); }
  // Room for n observations in all (a map file's loader knows each point's count).
  void reserve(std::size_t n) { entries_.reserve(n); }
  void shrink_to_fit() { entries_.shrink_to_fit(); }

  friend bool operator==(const Observations&, const Observations&) = default;

 private:
  std::vector<value_type>::iterator lower_bound(KeyframeId keyframe) {
    return std::lower_bound(entries_.begin(), entries_.end(), keyframe,
                            [](const value_type& e, KeyframeId k) { return e.first < k; });
  }
  std::vector<value_type>::const_iterator lower_bound(KeyframeId keyframe) const {
    return std::lower_bound(entries_.begin(), entries_.end(), keyframe,
                            [](const value_type& e, KeyframeId k) { return e.first < k; });
  }

  std::vector<value_type> entries_;  // ascending keyframe id, one entry per keyframe
};

inline std::uint32_t Observations::at(KeyframeId keyframe) const {
  const auto it = find(keyframe);
  if (it == end()) throw std::out_of_range("Observations::at: keyframe does not observe the point");
  return it->second;
}

}  // namespace coloc::slam::map
