// Save -> load gives the same map, field by field: synthetic maps, a map from a real SLAM run,
// a live save while another thread edits the map, and the exports that read without loading.
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <sys/stat.h>

#include <atomic>
#include <thread>

#include "slam/core/error.hpp"
#include "slam/mapdb/metadata.hpp"
#include "slam/mapdb/schema.hpp"
#include "slam/synthetic/synthetic_scene.hpp"
#include "slam/system/system.hpp"
#include "tests/slam/mapdb/map_compare.hpp"
#include "tests/slam/mapdb/mapdb_test_support.hpp"
#include "tests/testing/data.hpp"

namespace coloc::slam::mapdb {
namespace {

namespace fs = std::filesystem;
using test::map_difference;
using test::same_bits;

// Loop edges of the map, one per direction (as the file stores them).
std::size_t loop_edge_rows(const map::Map& m) {
  std::size_t n = 0;
  for (const auto& [id, kf] : m.keyframes())
    n += kf.loop_edges.size();
  return n;
}

// IMU rows of the map, as the file stores them.
std::size_t gravity_rows(const map::Map& m) {
  std::size_t n = 0;
  for (const auto& [id, kf] : m.keyframes())
    n += kf.gravity ? 1 : 0;
  return n;
}
std::size_t gyro_rows(const map::Map& m) {
  std::size_t n = 0;
  for (const auto& [id, kf] : m.keyframes())
    n += kf.gyro ? 1 : 0;
  return n;
}
std::size_t depth_rows(const map::Map& m) {
  std::size_t n = 0;
  for (const auto& [id, kf] : m.keyframes())
    n += kf.depth ? 1 : 0;
  return n;
}

// Turns a map file this build wrote into the file an older schema version was: the tables
// added after it dropped with their count/checksum entries (metadata checksum recomputed), the
// older user_version. Every other table is the same in all versions.
void make_schema_version(const fs::path& p, int version) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(p.c_str(), &db), SQLITE_OK);
  auto exec = [&](const std::string& statement) {
    EXPECT_EQ(sqlite3_exec(db, statement.c_str(), nullptr, nullptr, nullptr), SQLITE_OK)
        << statement << ": " << sqlite3_errmsg(db);
  };
  for (const detail::TableSchema& t : detail::tables()) {
    if (t.since <= version) continue;
    exec(std::string("DROP TABLE ") + t.name);
    exec(std::string("DELETE FROM metadata WHERE key IN ('count.") + t.name + "', 'checksum." +
         t.name + "')");
  }
  detail::MetadataEntries entries;
  sqlite3_stmt* s = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db, "SELECT key, value FROM metadata", -1, &s, nullptr), SQLITE_OK);
  while (sqlite3_step(s) == SQLITE_ROW) {
    entries[reinterpret_cast<const char*>(sqlite3_column_text(s, 0))] =
        reinterpret_cast<const char*>(sqlite3_column_text(s, 1));
  }
  sqlite3_finalize(s);
  exec("UPDATE metadata SET value = '" + detail::hex64(detail::metadata_checksum(entries)) +
       "' WHERE key = 'checksum.metadata'");
  exec("PRAGMA user_version = " + std::to_string(version));
  exec("VACUUM");
  sqlite3_close(db);
}

// `m` without what schema `version` does not store.
map::Map as_schema_version(map::Map m, int version) {
  m.for_each_keyframe([&](map::Keyframe& kf) {
    if (version < 2) kf.loop_edges.clear();
    if (version < 3) {
      kf.gravity.reset();
      kf.gyro.reset();
    }
    if (version < 4) kf.depth.reset();
  });
  return m;
}

void expect_same_metadata(const MapMetadata& a, const MapMetadata& b) {
  EXPECT_EQ(a.vocabulary_checksum, b.vocabulary_checksum);
  EXPECT_EQ(a.vocabulary_words, b.vocabulary_words);
  EXPECT_EQ(a.settings, b.settings);
  EXPECT_EQ(a.frame_name, b.frame_name);
  ASSERT_EQ(a.frame_from_slam.has_value(), b.frame_from_slam.has_value());
  if (a.frame_from_slam) {
    EXPECT_TRUE(same_bits(a.frame_from_slam->scale(), b.frame_from_slam->scale()));
    EXPECT_TRUE(same_bits(Eigen::Vector4d(a.frame_from_slam->so3().quaternion().coeffs()),
                          Eigen::Vector4d(b.frame_from_slam->so3().quaternion().coeffs())));
    EXPECT_TRUE(same_bits(a.frame_from_slam->translation(), b.frame_from_slam->translation()));
  }
  ASSERT_EQ(a.estimated_readout.has_value(), b.estimated_readout.has_value());
  if (a.estimated_readout) {
    EXPECT_TRUE(same_bits(*a.estimated_readout, *b.estimated_readout));
  }
  ASSERT_EQ(a.camera.has_value(), b.camera.has_value());
  if (a.camera) {
    const auto& p = std::get<PinholeCamera>(*a.camera);
    const auto& q = std::get<PinholeCamera>(*b.camera);
    EXPECT_EQ(p.width, q.width);
    EXPECT_EQ(p.height, q.height);
    EXPECT_EQ(p.intrinsic_matrix(), q.intrinsic_matrix());
    EXPECT_EQ(p.distortion, q.distortion);
  }
}

// Same place-recognition answers from both databases for every keyframe's BoW vector.
void expect_same_database(const map::Map& m, const bow::BowDatabase& a, const bow::BowDatabase& b) {
  ASSERT_EQ(a.size(), b.size());
  for (const auto& [id, kf] : m.keyframes()) {
    const auto ra = a.query(kf.frame.bow), rb = b.query(kf.frame.bow);
    ASSERT_EQ(ra.size(), rb.size());
    for (std::size_t i = 0; i < ra.size(); ++i) {
      EXPECT_EQ(ra[i].image, rb[i].image);
      EXPECT_TRUE(same_bits(ra[i].score, rb[i].score));
    }
  }
}

TEST(MapDb, SaveLoadIsIdenticalFieldByField) {
  const map::Map original = test::small_map();
  ASSERT_FALSE(original.erased_keyframes().empty());
  ASSERT_GT(loop_edge_rows(original), 0u);
  ASSERT_GT(gravity_rows(original), 0u);
  ASSERT_GT(gyro_rows(original), 0u);
  // Some keyframes with a depth image, some without (as in a map continued from an old file).
  ASSERT_GT(depth_rows(original), 0u);
  ASSERT_LT(depth_rows(original), original.keyframe_count());
  ASSERT_EQ(test_support::map_problem(original), "");
  const auto path = testing::temp_dir("mapdb_roundtrip") / "map.db";
  const MapMetadata metadata = test::test_metadata();
  const SaveReport saved = save_map(original, metadata, path);
  EXPECT_EQ(saved.keyframes, original.keyframe_count());
  EXPECT_EQ(saved.points, original.point_count());
  EXPECT_GT(saved.markers, 0u);
  EXPECT_EQ(saved.bytes, std::filesystem::file_size(path));
  const MapInfo info = read_map_info(path);
  EXPECT_EQ(info.schema_version, kSchemaVersion);
  EXPECT_EQ(info.counts.loop_edges, loop_edge_rows(original));
  EXPECT_EQ(info.counts.gravity_windows, gravity_rows(original));
  EXPECT_EQ(info.counts.gyro_links, gyro_rows(original));
  EXPECT_EQ(info.counts.keyframe_depths, depth_rows(original));

  // A localizer's load leaves the depth images in the file and the keyframes' BoW vectors in
  // the database, and nothing else: with those two put back, it equals the original.
  {
    LoadOptions light_options;
    light_options.keyframe_depth = false;
    light_options.keyframe_bow = false;
    LoadedMap light = load_map(path, test_support::vocabulary(), light_options);
    EXPECT_EQ(depth_rows(light.map), 0u);
    EXPECT_EQ(light.map.keyframe_count(), original.keyframe_count());
    EXPECT_EQ(light.map.point_count(), original.point_count());
    bow::BowDatabase database;
    for (const auto& [id, kf] : original.keyframes())
      database.add(id.value(), kf.frame.bow);
    expect_same_database(original, database, light.database);
    light.map.for_each_keyframe([&](map::Keyframe& kf) {
      EXPECT_TRUE(kf.frame.bow.empty()) << "keyframe " << kf.id.value();
      const map::Keyframe& full = *original.keyframe(kf.id);
      kf.frame.bow = full.frame.bow;
      kf.depth = full.depth;
    });
    EXPECT_EQ(map_difference(original, light.map), "");
  }

  LoadedMap loaded = load_map(path, test_support::vocabulary());
  EXPECT_EQ(map_difference(original, loaded.map), "");
  EXPECT_EQ(map_difference(loaded.map, original), "");
  EXPECT_EQ(test_support::map_problem(loaded.map), "");
  expect_same_metadata(metadata, loaded.metadata);
  EXPECT_FALSE(loaded.metadata.coloc_version.empty());
  EXPECT_EQ(loaded.metadata.saved_utc.size(), 20u);
  ASSERT_EQ(loaded.geometries.size(), 1u);

  bow::BowDatabase database;
  for (const auto& [id, kf] : original.keyframes())
    database.add(id.value(), kf.frame.bow);
  expect_same_database(original, database, loaded.database);

  // Ids continue where the saved map stopped (erased ids are never reissued).
  map::Map a = original, b = loaded.map;
  EXPECT_EQ(a.next_keyframe_id(), b.next_keyframe_id());
  EXPECT_EQ(a.next_point_id(), b.next_point_id());

  // Saving the loaded map again gives the same content (the checksums cover every row).
  const auto again = path.parent_path() / "again.db";
  save_map(loaded.map, loaded.metadata, again);
  const MapInfo i1 = read_map_info(path), i2 = read_map_info(again);
  EXPECT_EQ(i1.counts.observations, i2.counts.observations);
  EXPECT_EQ(map_difference(original, load_map(again, test_support::vocabulary()).map), "");
}

// Files of older schema versions still load and verify, without what they did not store
// (version 1: loop edges; version 2: the IMU's measurements; version 3: the keyframes' depth
// images); saving one again writes the current version.
TEST(MapDb, OlderSchemaVersionsLoadWithoutWhatTheyLacked) {
  const map::Map original = test::small_map(6, 24);
  ASSERT_GT(loop_edge_rows(original), 0u);
  ASSERT_GT(gyro_rows(original), 0u);
  ASSERT_GT(depth_rows(original), 0u);
  const fs::path dir = testing::temp_dir("mapdb_older");
  for (int version = 1; version < kSchemaVersion; ++version) {
    SCOPED_TRACE("schema version " + std::to_string(version));
    const fs::path path = dir / ("v" + std::to_string(version) + ".db");
    save_map(original, test::test_metadata(), path);
    make_schema_version(path, version);
    const MapInfo info = read_map_info(path);
    EXPECT_EQ(info.schema_version, version);
    EXPECT_EQ(info.counts.loop_edges, version >= 2 ? loop_edge_rows(original) : 0u);
    EXPECT_EQ(info.counts.gyro_links, version >= 3 ? gyro_rows(original) : 0u);
    EXPECT_EQ(info.counts.keyframe_depths, 0u);
    EXPECT_EQ(info.counts.keyframes, original.keyframe_count());
    const VerifyReport v = verify_map(path, &test_support::vocabulary());
    EXPECT_TRUE(v.ok()) << (v.problems.empty() ? "" : v.problems.front());

    const LoadedMap loaded = load_map(path, test_support::vocabulary());
    const map::Map expected = as_schema_version(original, version);
    EXPECT_EQ(map_difference(expected, loaded.map), "");
    EXPECT_EQ(map_difference(loaded.map, expected), "");
    // Without the clearing above, the comparison sees the loss.
    EXPECT_NE(map_difference(original, loaded.map), "");

    const fs::path again = dir / ("v" + std::to_string(version) + "_again.db");
    save_map(loaded.map, loaded.metadata, again);
    EXPECT_EQ(read_map_info(again).schema_version, kSchemaVersion);
    EXPECT_TRUE(verify_map(again, &test_support::vocabulary()).ok());
    EXPECT_EQ(map_difference(expected, load_map(again, test_support::vocabulary()).map), "");
  }
}

TEST(MapDb, EmptyMapRoundTrips) {
  const auto path = testing::temp_dir("mapdb_empty") / "empty.db";
  MapMetadata metadata = test::test_metadata();
  metadata.camera.reset();
  metadata.frame_from_slam.reset();
  metadata.estimated_readout.reset();  // a map made with the readout in its settings
  save_map(map::Map{}, metadata, path);
  const LoadedMap loaded = load_map(path, test_support::vocabulary());
  EXPECT_EQ(loaded.map.keyframe_count(), 0u);
  EXPECT_EQ(loaded.map.point_count(), 0u);
  expect_same_metadata(metadata, loaded.metadata);
  EXPECT_TRUE(verify_map(path, &test_support::vocabulary()).ok());
}

TEST(MapDb, MapOfASlamRunRoundTrips) {
  synthetic::SyntheticSceneOptions so;
  so.frames = 45;
  const synthetic::SyntheticRgbdScene scene(so);
  system::SystemOptions options;
  options.tracking.wait_for_sink = true;
  system::System slam(scene.settings(), test_support::vocabulary(), options);
  for (int i = 0; i < scene.size(); ++i) {
    const synthetic::SyntheticFrame f = scene.frame(i);
    slam.track(f.color, f.depth, f.timestamp);
  }
  slam.shutdown();
  const auto path = testing::temp_dir("mapdb_slam") / "slam.db";
  MapMetadata metadata = test::test_metadata();
  metadata.camera = scene.settings().camera;
  slam.with_map([&](const map::Map& m) { save_map(m, metadata, path); });
  const LoadedMap loaded = load_map(path, test_support::vocabulary());
  const std::string difference =
      slam.with_map([&](const map::Map& m) { return map_difference(m, loaded.map); });
  EXPECT_EQ(difference, "");
  EXPECT_GT(loaded.map.keyframe_count(), 2u);
  EXPECT_GT(loaded.map.point_count(), 100u);
  // The keyframe trajectory read straight from the file is the System's.
  const Trajectory from_file = read_keyframe_trajectory(path);
  const Trajectory from_slam = slam.keyframe_trajectory();
  ASSERT_EQ(from_file.size(), from_slam.size());
  for (std::size_t i = 0; i < from_file.size(); ++i) {
    EXPECT_EQ(from_file[i].timestamp, from_slam[i].timestamp);
    EXPECT_LT(translation_distance(from_file[i].world_from_cam, from_slam[i].world_from_cam),
              1e-12);
  }
}

TEST(MapDb, PointsStreamWithTheirObservationCounts) {
  const map::Map original = test::small_map(3, 12);
  const auto path = testing::temp_dir("mapdb_points") / "map.db";
  save_map(original, test::test_metadata(), path);
  std::size_t n = 0;
  MapPointId last;
  for_each_point(path, [&](const PointRecord& r) {
    const map::MapPoint* p = original.point(r.id);
    ASSERT_NE(p, nullptr);
    EXPECT_TRUE(same_bits(r.position, p->position));
    EXPECT_EQ(r.observations, p->observations.size());
    EXPECT_TRUE(!last.valid() || last < r.id);
    last = r.id;
    ++n;
  });
  EXPECT_EQ(n, original.point_count());
}

// A copy of keyframe `from` under a new id that shares 20 of its points and is connected to
// it, as tracking and local mapping would insert one.
KeyframeId add_copy(map::Map& m, KeyframeId from) {
  map::Keyframe kf;
  kf.id = m.next_keyframe_id();
  kf.frame = m.keyframe(from)->frame;
  kf.depth = m.keyframe(from)->depth;
  std::fill(kf.frame.points.begin(), kf.frame.points.end(), MapPointId::invalid());
  const KeyframeId id = m.add_keyframe(std::move(kf)).id;
  const std::vector<MapPointId> shared = m.keyframe(from)->frame.points;
  for (std::uint32_t i = 0, n = 0; i < shared.size() && n < 20; ++i) {
    if (!shared[i].valid()) continue;
    m.add_observation(shared[i], id, i);
    ++n;
  }
  m.update_connections(id);
  return id;
}

TEST(MapDb, LiveSaveIsConsistentWhileAnotherThreadEditsTheMap) {
  map::Map m = test::small_map(5, 40);
  std::mutex mutex;
  std::atomic<bool> stop{false};
  // Tracking, mapping and loop closing as the save sees them: new keyframes, culled keyframes,
  // moved poses, loop edges.
  // The editor runs until the saves have seen both kinds of change: how many edits a save
  // overlaps depends on the machine's load, so the test waits for the events, not a count.
  std::thread editor([&] {
    for (int step = 0; !stop; ++step) {
      {
        std::lock_guard lock(mutex);
        std::vector<KeyframeId> ids;
        for (const auto& [id, kf] : m.keyframes())
          ids.push_back(id);
        std::sort(ids.begin(), ids.end());
        const KeyframeId added = add_copy(m, ids.back());
        if (step % 10 == 0) {  // a loop closed between the new keyframe and an older one
          const KeyframeId old = ids[ids.size() / 2];
          m.keyframe(added)->loop_edges.insert(old);
          m.keyframe(old)->loop_edges.insert(added);
        }
        // Erasing faster once the map has grown keeps a long run's saves short.
        if ((step % 4 == 0 && ids.size() > 30) || ids.size() > 80)
          m.erase_keyframe(ids[1 + static_cast<std::size_t>(step) % 8]);
        m.keyframe(ids.back())->frame.cam_from_world.translation().x() += 0.001;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  });
  const auto path = testing::temp_dir("mapdb_live") / "live.db";
  SaveOptions options;
  options.chunk_keyframes = 2;
  SaveReport report;
  std::size_t late = 0, dropped = 0;
  // The deadline only stops a stuck run (CI runs the suite on a busy 2-core machine).
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  for (int saves = 0;
       saves < 3 || ((late == 0 || dropped == 0) && std::chrono::steady_clock::now() < deadline);
       ++saves) {
    report = save_live_map(m, mutex, test::test_metadata(), path, options);
    late += report.late_keyframes;
    dropped += report.dropped_keyframes;
  }
  stop = true;
  editor.join();
  // Both ways the map changes under a save happened.
  EXPECT_GT(late, 0u);
  EXPECT_GT(dropped, 0u);
  EXPECT_GT(report.locks, 10u);  // many short holds, not one long one
  const LoadedMap loaded = load_map(path, test_support::vocabulary());
  EXPECT_EQ(test_support::map_problem(loaded.map), "");
  // Every saved keyframe that still exists has the features it has now (they never change).
  std::size_t compared = 0;
  for (const auto& [id, kf] : loaded.map.keyframes()) {
    const map::Keyframe* now = m.keyframe(id);
    if (!now) continue;
    EXPECT_EQ(kf.frame.features.descriptors, now->frame.features.descriptors);
    EXPECT_EQ(kf.frame.depth, now->frame.depth);
    EXPECT_EQ(kf.depth, now->depth);
    ++compared;
  }
  EXPECT_GT(compared, 10u);
  // Without concurrent edits, a live save equals a plain one (loop edges included).
  EXPECT_GT(loop_edge_rows(m), 0u);
  save_live_map(m, mutex, test::test_metadata(), path, options);
  EXPECT_EQ(map_difference(m, load_map(path, test_support::vocabulary()).map), "");
}

// A FIFO map file is refused saying it is a FIFO (it said "no such map file").
TEST(MapDb, FifoMapFileIsNamedForWhatItIs) {
  const auto path = testing::temp_dir("mapdb_fifo") / "map.db";
  ASSERT_EQ(::mkfifo(path.c_str(), 0600), 0);
  try {
    load_map(path, test_support::vocabulary());
    FAIL() << "a FIFO was opened";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("map file is a FIFO"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace coloc::slam::mapdb
