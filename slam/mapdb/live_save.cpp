// save_live_map(): saving a map that tracking and local mapping keep changing, holding their
// mutex only for short copies (the steps are described in mapdb.hpp).
#include <spdlog/spdlog.h>

#include <algorithm>
#include <numeric>
#include <optional>
#include <span>
#include <thread>

#include "slam/core/atomic_file.hpp"
#include "slam/mapdb/mapdb.hpp"
#include "slam/mapdb/save_common.hpp"
#include "slam/mapdb/writer.hpp"

namespace coloc::slam::mapdb {

namespace fs = std::filesystem;

namespace detail {
namespace {

// The per-keypoint arrays of a keyframe and its depth image, copied under the lock into buffers
// reused from one keyframe to the next, and encoded after the lock is released.
struct FeatureCopy {
  KeyframeId id;
  std::vector<features::Keypoint> keypoints;
  std::vector<features::Descriptor> descriptors;
  std::vector<float> depth, u_right;
  std::vector<std::uint8_t> outlier;
  std::optional<map::KeyframeDepth> depth_image;

  void copy(const map::Keyframe& kf) {
    id = kf.id;
    keypoints.assign(kf.frame.features.keypoints.begin(), kf.frame.features.keypoints.end());
    descriptors.assign(kf.frame.features.descriptors.begin(), kf.frame.features.descriptors.end());
    depth.assign(kf.frame.depth.begin(), kf.frame.depth.end());
    u_right.assign(kf.frame.u_right.begin(), kf.frame.u_right.end());
    outlier.assign(kf.frame.outlier.begin(), kf.frame.outlier.end());
    if (kf.depth) {
      if (!depth_image) depth_image.emplace();
      // Assigned member by member, so the pixel buffer is reused.
      depth_image->width = kf.depth->width;
      depth_image->height = kf.depth->height;
      depth_image->factor = kf.depth->factor;
      depth_image->millimetres.assign(kf.depth->millimetres.begin(), kf.depth->millimetres.end());
    } else {
      depth_image.reset();
    }
  }
  void write(MapWriter& w, EncodedFeatures& buffer) const {
    buffer.id = id;
    encode_keypoints(keypoints, depth, u_right, outlier, buffer.keypoints);
    encode_descriptors(descriptors, buffer.descriptors);
    w.features(buffer);
    if (depth_image) w.depth(id, *depth_image);
  }
};

// A vector sized and touched before the lock is taken, then filled under it: the page faults
// of fresh memory (tens of MB for a large map) would otherwise happen while tracking waits.
template <typename T>
class Prefilled {
 public:
  void prepare(std::size_t expected) { data_.resize(expected + expected / 32 + 1024); }
  void push(const T& v) {
    if (n_ < data_.size()) {
      data_[n_] = v;
    } else {
      data_.push_back(v);  // more than expected: grows under the lock, still correct
    }
    ++n_;
  }
  // Room for k more values at end(); append() then keeps the first `used` of them.
  T* space(std::size_t k) {
    if (n_ + k > data_.size()) data_.resize(n_ + k);
    return data_.data() + n_;
  }
  void append(std::size_t used) { n_ += used; }
  std::size_t size() const { return n_; }
  T* begin() { return data_.data(); }
  T* end() { return data_.data() + n_; }
  std::span<const T> range(std::size_t first, std::size_t last) const {
    return {data_.data() + first, last - first};
  }

 private:
  std::vector<T> data_;
  std::size_t n_ = 0;
};

// What a map holds besides the features written in step 1, as flat arrays: a keyframe's
// observations, edges and markers are ranges of them.
class Snapshot {
 public:
  struct Sizes {
    std::size_t keyframes = 0, points = 0, observations = 0, edges = 0, loop_edges = 0;
  };
  void prepare(const Sizes& s);
  // Under the lock: a plain copy, no sorting, no allocation beyond prepare()'s estimates.
  void take(const map::Map& map, const MapWriter& w);
  // After the lock: the keyframes present at the copy (sorted), for dropping erased ones.
  std::vector<KeyframeId> keyframe_ids() const;
  void write(MapWriter& w, Counter& progress);
  std::size_t late_keyframes() const { return late_.size(); }
  const map::MapBookkeeping& bookkeeping() const { return bookkeeping_; }

 private:
  struct Entry {
    KeyframeRow row;
    std::size_t obs_begin = 0, obs_end = 0, edge_begin = 0, edge_end = 0;
    std::size_t marker_begin = 0, marker_end = 0, loop_begin = 0, loop_end = 0;
  };
  Prefilled<Entry> entries_;
  Prefilled<std::uint32_t> obs_keypoint_;
  Prefilled<MapPointId> obs_point_;
  Prefilled<std::pair<KeyframeId, int>> edges_;
  Prefilled<KeyframeId> loop_edges_;  // each keyframe's in increasing order (from its std::set)
  std::vector<markers::MarkerObservation> markers_;
  Prefilled<PointRow> points_;
  std::vector<FeatureCopy> late_;  // keyframes created since step 1
  map::MapBookkeeping bookkeeping_;
};

void Snapshot::prepare(const Sizes& s) {
  entries_.prepare(s.keyframes);
  obs_keypoint_.prepare(s.observations);
  obs_point_.prepare(s.observations);
  edges_.prepare(s.edges);
  loop_edges_.prepare(s.loop_edges);
  points_.prepare(s.points);
}

void Snapshot::take(const map::Map& map, const MapWriter& w) {
  // The points on the second core meanwhile: tracking and local mapping wait for this lock, so
  // both cores may as well shorten it. Concurrent const reads of the Map are safe.
  std::thread point_copier([&] {
    for (const auto& [id, p] : map.points())
      points_.push(PointRow::of(p));
  });
  for (const auto& [id, kf] : map.keyframes()) {
    Entry e{.row = KeyframeRow::of(kf)};
    e.obs_begin = obs_point_.size();
    // Branch-free compaction of the valid entries: which keypoints hold a point is random, and
    // a branch on it mispredicts half the time (this loop is most of the snapshot's cost).
    const std::vector<MapPointId>& points = kf.frame.points;
    std::uint32_t* keypoint = obs_keypoint_.space(points.size());
    MapPointId* point = obs_point_.space(points.size());
    std::size_t n = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
      keypoint[n] = static_cast<std::uint32_t>(i);
      point[n] = points[i];
      n += points[i].valid() ? 1 : 0;
    }
    obs_keypoint_.append(n);
    obs_point_.append(n);
    e.obs_end = obs_point_.size();
    e.edge_begin = edges_.size();
    for (const auto& edge : kf.covisibility)
      edges_.push(edge);
    e.edge_end = edges_.size();
    e.loop_begin = loop_edges_.size();
    for (KeyframeId other : kf.loop_edges)
      loop_edges_.push(other);
    e.loop_end = loop_edges_.size();
    e.marker_begin = markers_.size();
    markers_.insert(markers_.end(), kf.markers.begin(), kf.markers.end());
    e.marker_end = markers_.size();
    entries_.push(e);
    if (!w.has_features(id)) late_.emplace_back().copy(kf);
  }
  bookkeeping_ = map.bookkeeping();
  point_copier.join();
}

std::vector<KeyframeId> Snapshot::keyframe_ids() const {
  std::vector<KeyframeId> ids;
  for (const Entry& e : entries_.range(0, entries_.size()))
    ids.push_back(e.row.id);
  std::sort(ids.begin(), ids.end());
  return ids;
}

void Snapshot::write(MapWriter& w, Counter& progress) {
  std::sort(entries_.begin(), entries_.end(),
            [](const Entry& a, const Entry& b) { return a.row.id < b.row.id; });
  std::sort(points_.begin(), points_.end(),
            [](const PointRow& a, const PointRow& b) { return a.id < b.id; });
  EncodedFeatures buffer;
  for (const FeatureCopy& f : late_)
    f.write(w, buffer);
  const std::span<const markers::MarkerObservation> markers(markers_);
  for (const Entry& e : entries_.range(0, entries_.size())) {
    w.keyframe(e.row);
    w.markers(e.row.id, markers.subspan(e.marker_begin, e.marker_end - e.marker_begin));
    w.observations(e.row.id, obs_keypoint_.range(e.obs_begin, e.obs_end),
                   obs_point_.range(e.obs_begin, e.obs_end));
    w.covisibility(e.row.id, edges_.range(e.edge_begin, e.edge_end));
    w.loop_edges(e.row.id, loop_edges_.range(e.loop_begin, e.loop_end));
    progress.advance();
  }
  for (const PointRow& p : points_.range(0, points_.size())) {
    w.point(p);
    progress.advance();
  }
  write_erased(w, bookkeeping_.erased);
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

// Step 1: the features of the keyframes present now, a chunk per lock. Returns the sizes the
// snapshot will need, as seen meanwhile.
Snapshot::Sizes write_features_in_chunks(const map::Map& map, LockedRunner& locked, MapWriter& w,
                                         std::size_t chunk, Counter& progress) {
  std::vector<KeyframeId> ids;
  Snapshot::Sizes sizes;
  locked([&] {
    ids = sorted_ids(map.keyframes());
    sizes.points = map.point_count();
  });
  sizes.keyframes = ids.size();
  std::vector<FeatureCopy> copies(chunk);
  EncodedFeatures buffer;
  for (std::size_t first = 0; first < ids.size(); first += chunk) {
    const std::size_t last = std::min(ids.size(), first + chunk);
    std::size_t n = 0;
    locked([&] {
      for (std::size_t i = first; i < last; ++i) {
        const map::Keyframe* kf = map.keyframe(ids[i]);
        if (!kf) continue;
        copies[n++].copy(*kf);
        sizes.edges += kf->covisibility.size();
        sizes.loop_edges += kf->loop_edges.size();
        sizes.observations +=
            kf->frame.size() - static_cast<std::size_t>(std::count(
                                   kf->frame.points.begin(), kf->frame.points.end(), MapPointId()));
      }
    });
    for (std::size_t i = 0; i < n; ++i) {
      copies[i].write(w, buffer);
      progress.advance();
    }
  }
  return sizes;
}

}  // namespace
}  // namespace detail

SaveReport save_live_map(const map::Map& map, std::mutex& mutex, const MapMetadata& metadata,
                         const fs::path& path, const SaveOptions& options) {
  using namespace detail;
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
  const Snapshot::Sizes sizes =
      write_features_in_chunks(map, locked, w, options.chunk_keyframes, progress);
  Snapshot snapshot;
  snapshot.prepare(sizes);
  locked([&] { snapshot.take(map, w); });
  // Keyframes erased since their features were written are not in the snapshot.
  const std::size_t dropped = w.drop_features_except(snapshot.keyframe_ids());
  snapshot.write(w, progress);
  w.finish(snapshot.bookkeeping().first_keyframe, snapshot.bookkeeping().next_keyframe_id,
           snapshot.bookkeeping().next_point_id);
  out.commit(options.sync);
  progress.finish();
  SaveReport report = finish_report(w, path, start);
  report.locks = locks.locks;
  report.max_lock_ms = locks.max_lock_ms;
  report.total_lock_ms = locks.total_lock_ms;
  report.late_keyframes = snapshot.late_keyframes();
  report.dropped_keyframes = dropped;
  spdlog::debug(
      "saved a live map: {} keyframes ({} created, {} erased during the save), {} points, {} "
      "locks (longest {:.2f} ms)",
      report.keyframes, report.late_keyframes, dropped, report.points, report.locks,
      report.max_lock_ms);
  return report;
}

}  // namespace coloc::slam::mapdb
