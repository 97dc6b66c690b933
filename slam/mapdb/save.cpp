// save_map(): a map nobody changes meanwhile, through MapWriter into an AtomicFile.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>

#include "slam/core/atomic_file.hpp"
#include "slam/core/error.hpp"
#include "slam/mapdb/mapdb.hpp"
#include "slam/mapdb/save_common.hpp"
#include "slam/mapdb/writer.hpp"

namespace coloc::slam::mapdb {

namespace fs = std::filesystem;
using detail::Clock;
using detail::Counter;
using detail::EncodedFeatures;
using detail::KeyframeRow;
using detail::MapWriter;
using detail::PointRow;
using detail::sorted_ids;

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
    if (kf.depth) w.depth(id, *kf.depth);
    w.keyframe(KeyframeRow::of(kf));
    w.markers(id, kf.markers);
    w.observations(id, kf.frame.points);
    w.covisibility(id, kf.covisibility);
    w.loop_edges(id, kf.loop_edges);
    progress.advance();
  }
  for (MapPointId id : points) {
    w.point(PointRow::of(*map.point(id)));
    progress.advance();
  }
  detail::write_erased(w, map.erased_keyframes());
  const map::MapBookkeeping b = map.bookkeeping();
  w.finish(b.first_keyframe, b.next_keyframe_id, b.next_point_id);
  out.commit(options.sync);
  progress.finish();
  SaveReport report = detail::finish_report(w, path, start);
  spdlog::debug("saved {} keyframes, {} points to {} ({} bytes, {:.2f} s)", report.keyframes,
                report.points, path.string(), report.bytes, report.seconds);
  return report;
}

}  // namespace coloc::slam::mapdb
