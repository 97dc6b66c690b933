#pragma once
// Pieces save_map() and save_live_map() share (internal to slam/mapdb).
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <unordered_map>
#include <vector>

#include "slam/mapdb/mapdb.hpp"
#include "slam/mapdb/writer.hpp"

namespace coloc::slam::mapdb::detail {

using Clock = std::chrono::steady_clock;

// Calls the progress function every 256 rows and at the end.
class Counter {
 public:
  Counter(const ProgressFn& fn, std::uint64_t total) : fn_(fn), total_(total) {}
  void advance() {
    if (++done_ % 256 == 0 && fn_) fn_(done_, total_);
  }
  void finish() {
    if (fn_) fn_(total_, total_);
  }

 private:
  const ProgressFn& fn_;
  std::uint64_t total_;
  std::uint64_t done_ = 0;
};

template <typename Id, typename Value>
std::vector<Id> sorted_ids(const std::unordered_map<Id, Value>& items) {
  std::vector<Id> ids;
  ids.reserve(items.size());
  for (const auto& [id, v] : items)
    ids.push_back(id);
  std::sort(ids.begin(), ids.end());
  return ids;
}

inline void write_erased(MapWriter& w,
                         const std::unordered_map<KeyframeId, map::ErasedKeyframe>& erased) {
  for (KeyframeId id : sorted_ids(erased))
    w.erased(id, erased.at(id));
}

inline SaveReport finish_report(const MapWriter& w, const std::filesystem::path& path,
                                Clock::time_point start) {
  SaveReport r;
  r.keyframes = w.counts().keyframes;
  r.points = w.counts().points;
  r.observations = w.counts().observations;
  r.markers = w.counts().markers;
  r.bytes = std::filesystem::file_size(path);
  r.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return r;
}

}  // namespace coloc::slam::mapdb::detail
