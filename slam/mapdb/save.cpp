// save_map() and save_live_map(): the map through MapWriter into an AtomicFile.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>

#include "slam/core/error.hpp"
#include "slam/mapdb/atomic_file.hpp"
#include "slam/mapdb/mapdb.hpp"
#include "slam/mapdb/writer.hpp"

namespace coloc::slam::mapdb {

namespace fs = std::filesystem;
using detail::EncodedFeatures;
using detail::KeyframeRow;
using detail::MapWriter;
using detail::PointRow;
using Clock = std::chrono::steady_clock;

void SaveOptions::check() const {
  if (cache_mib < 1 || cache_mib > 4096) throw Error("SaveOptions: cache_mib not in 1..4096");
  if (page_size < 512 || page_size > 65536 || (page_size & (page_size - 1)) != 0)
    throw Error("SaveOptions: page_size must be a power of two in 512..65536");
  if (chunk_keyframes < 1) throw Error("SaveOptions: chunk_keyframes must be at least 1");
}

std::uint64_t vocabulary_checksum(const bow::Vocabulary& vocabulary) {
  const std::vector<std::uint8_t> bytes = vocabulary.serialize();
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < 8; ++i)
    v |= static_cast<std::uint64_t>(bytes[bytes.size() - 8 + i]) << (8 * i);
  return v;
}

namespace {

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

void write_erased(MapWriter& w, const std::unordered_map<KeyframeId, map::ErasedKeyframe>& erased) {
  for (KeyframeId id : sorted_ids(erased))
    w.erased(id, erased.at(id));
}

SaveReport finish_report(const MapWriter& w, const fs::path& path, Clock::time_point start) {
  SaveReport r;
  r.keyframes = w.counts().keyframes;
  r.points = w.counts().points;
  r.observations = w.counts().observations;
  r.markers = w.counts().markers;
  r.bytes = fs::file_size(path);
  r.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return r;
}

}  // namespace

SaveReport save_map(const map::Map& map, const MapMetadata& metadata, const fs::path& path,
                    const SaveOptions& options) {
  options.check();
  const auto start = Clock::now();
  AtomicFile::remove_stale(path);
  AtomicFile out(path);
  const std::vector<KeyframeId> keyframes = sorted_ids(map.keyframes());
  const std::vector<MapPointId> points = sorted_ids(map.points());
  Counter progress(options.progress, keyframes.size() + points.size());
  MapWriter w(out.temp_path(), options, metadata);
  EncodedFeatures features;
  for (KeyframeId id : keyframes) {
    const map::Keyframe& kf = *map.keyframe(id);
    features.encode(id, kf.frame);
    w.features(features);
    w.keyframe(KeyframeRow::of(kf));
    w.markers(id, kf.markers);
    w.observations(id, kf.frame.points);
    w.covisibility(id, kf.covisibility);
    progress.advance();
  }
  for (MapPointId id : points) {
    w.point(PointRow::of(*map.point(id)));
    progress.advance();
  }
  write_erased(w, map.erased_keyframes());
  const map::MapBookkeeping b = map.bookkeeping();
  w.finish(b.first_keyframe, b.next_keyframe_id, b.next_point_id);
  out.commit(options.sync);
  progress.finish();
  SaveReport report = finish_report(w, path, start);
  spdlog::debug("saved {} keyframes, {} points to {} ({} bytes, {:.2f} s)", report.keyframes,
                report.points, path.string(), report.bytes, report.seconds);
  return report;
}

namespace {

// The per-keypoint arrays of a keyframe, copied under the lock into buffers reused from one
// keyframe to the next, and encoded after the lock is released.
struct FeatureCopy {
  KeyframeId id;
  std::vector<features::Keypoint> keypoints;
  std::vector<features::Descriptor> descriptors;
  std::vector<float> depth, u_right;
  std::vector<std::uint8_t> outlier;

  void copy(const map::Keyframe& kf) {
    id = kf.id;
    keypoints.assign(kf.frame.features.keypoints.begin(), kf.frame.features.keypoints.end());
    descriptors.assign(kf.frame.features.descriptors.begin(), kf.frame.features.descriptors.end());
    depth.assign(kf.frame.depth.begin(), kf.frame.depth.end());
    u_right.assign(kf.frame.u_right.begin(), kf.frame.u_right.end());
    outlier.assign(kf.frame.outlier.begin(), kf.frame.outlier.end());
  }
  void write(MapWriter& w, EncodedFeatures& buffer) const {
    buffer.id = id;
    detail::encode_keypoints(keypoints, depth, u_right, outlier, buffer.keypoints);
    detail::encode_descriptors(descriptors, buffer.descriptors);
    w.features(buffer);
  }
};

struct KeyframeSnapshot {
  KeyframeRow row;
  std::vector<markers::MarkerObservation> markers;
  std::map<KeyframeId, int> covisibility;
  std::vector<MapPointId> points;
};

// Everything but the features of keyframes already written: small next to the features, and
// copied without sorting (sorting happens after the lock is released).
struct Snapshot {
  std::vector<KeyframeSnapshot> keyframes;
  std::vector<PointRow> points;
  std::vector<FeatureCopy> late_features;  // keyframes created since their features were copied
  map::MapBookkeeping bookkeeping;
};

Snapshot take_snapshot(const map::Map& map, const MapWriter& w) {
  Snapshot s;
  s.keyframes.reserve(map.keyframe_count());
  for (const auto& [id, kf] : map.keyframes()) {
    s.keyframes.push_back({KeyframeRow::of(kf), kf.markers, kf.covisibility, kf.frame.points});
    if (!w.has_features(id)) s.late_features.emplace_back().copy(kf);
  }
  s.points.reserve(map.point_count());
  for (const auto& [id, p] : map.points())
    s.points.push_back(PointRow::of(p));
  s.bookkeeping = map.bookkeeping();
  return s;
}

// Runs f() under the mutex and records how long it was held.
class LockedRunner {
 public:
  LockedRunner(std::mutex& mutex, SaveReport& report) : mutex_(mutex), report_(report) {}
  template <typename F>
  void operator()(F&& f) {
    std::lock_guard lock(mutex_);
    const auto t0 = Clock::now();
    f();
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    ++report_.locks;
    report_.total_lock_ms += ms;
    report_.max_lock_ms = std::max(report_.max_lock_ms, ms);
  }

 private:
  std::mutex& mutex_;
  SaveReport& report_;
};

// Step 1 of save_live_map(): the features of the keyframes present now, a chunk per lock.
void write_features_in_chunks(const map::Map& map, LockedRunner& locked, MapWriter& w,
                              std::size_t chunk, Counter& progress) {
  std::vector<KeyframeId> ids;
  locked([&] { ids = sorted_ids(map.keyframes()); });
  std::vector<FeatureCopy> copies(chunk);
  EncodedFeatures buffer;
  for (std::size_t first = 0; first < ids.size(); first += chunk) {
    const std::size_t last = std::min(ids.size(), first + chunk);
    std::size_t n = 0;
    locked([&] {
      for (std::size_t i = first; i < last; ++i) {
        if (const map::Keyframe* kf = map.keyframe(ids[i])) copies[n++].copy(*kf);
      }
    });
    for (std::size_t i = 0; i < n; ++i) {
      copies[i].write(w, buffer);
      progress.advance();
    }
  }
}

// Step 3: the snapshot, in key order.
void write_snapshot(Snapshot& s, MapWriter& w, Counter& progress) {
  std::sort(s.keyframes.begin(), s.keyframes.end(),
            [](const auto& a, const auto& b) { return a.row.id < b.row.id; });
  std::sort(s.points.begin(), s.points.end(),
            [](const auto& a, const auto& b) { return a.id < b.id; });
  EncodedFeatures buffer;
  for (const FeatureCopy& f : s.late_features)
    f.write(w, buffer);
  for (const KeyframeSnapshot& k : s.keyframes) {
    w.keyframe(k.row);
    w.markers(k.row.id, k.markers);
    w.observations(k.row.id, k.points);
    w.covisibility(k.row.id, k.covisibility);
    progress.advance();
  }
  for (const PointRow& p : s.points) {
    w.point(p);
    progress.advance();
  }
  write_erased(w, s.bookkeeping.erased);
}

}  // namespace

SaveReport save_live_map(const map::Map& map, std::mutex& mutex, const MapMetadata& metadata,
                         const fs::path& path, const SaveOptions& options) {
  options.check();
  const auto start = Clock::now();
  AtomicFile::remove_stale(path);
  AtomicFile out(path);
  SaveReport locks;
  LockedRunner locked(mutex, locks);
  std::size_t keyframes = 0, points = 0;
  locked([&] {
    keyframes = map.keyframe_count();
    points = map.point_count();
  });
  Counter progress(options.progress, 2 * keyframes + points);
  MapWriter w(out.temp_path(), options, metadata);
  write_features_in_chunks(map, locked, w, options.chunk_keyframes, progress);
  Snapshot snapshot;
  locked([&] { snapshot = take_snapshot(map, w); });
  // Keyframes erased since their features were written are not in the snapshot.
  std::vector<KeyframeId> present;
  for (const KeyframeSnapshot& k : snapshot.keyframes)
    present.push_back(k.row.id);
  std::sort(present.begin(), present.end());
  const std::size_t dropped = w.drop_features_except(present);
  const std::size_t late = snapshot.late_features.size();
  write_snapshot(snapshot, w, progress);
  const map::MapBookkeeping& b = snapshot.bookkeeping;
  w.finish(b.first_keyframe, b.next_keyframe_id, b.next_point_id);
  out.commit(options.sync);
  progress.finish();
  SaveReport report = finish_report(w, path, start);
  report.locks = locks.locks;
  report.max_lock_ms = locks.max_lock_ms;
  report.total_lock_ms = locks.total_lock_ms;
  report.late_keyframes = late;
  report.dropped_keyframes = dropped;
  spdlog::debug(
      "saved a live map: {} keyframes ({} created, {} erased during the save), {} points, {} "
      "locks (longest {:.2f} ms)",
      report.keyframes, late, dropped, report.points, report.locks, report.max_lock_ms);
  return report;
}

}  // namespace coloc::slam::mapdb
