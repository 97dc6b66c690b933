// Damaged, truncated, edited, foreign and newer map files are coloc::Errors naming the file and
// the table (and row); failed saves never replace the previous file.
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fstream>
#include <functional>
#include <random>
#include <set>

#include "slam/core/atomic_file.hpp"
#include "slam/core/error.hpp"
#include "slam/mapdb/writer.hpp"
#include "tests/slam/mapdb/map_compare.hpp"
#include "tests/slam/mapdb/mapdb_test_support.hpp"
#include "tests/testing/data.hpp"

namespace coloc::slam::mapdb {
namespace {

namespace fs = std::filesystem;
using test::map_difference;

std::vector<char> read_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_bytes(const fs::path& p, const std::vector<char>& bytes) {
  std::ofstream(p, std::ios::binary | std::ios::trunc)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

void sql(const fs::path& p, const std::string& statement) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(p.c_str(), &db), SQLITE_OK);
  EXPECT_EQ(sqlite3_exec(db, statement.c_str(), nullptr, nullptr, nullptr), SQLITE_OK)
      << sqlite3_errmsg(db);
  sqlite3_close(db);
}

// The message of the coloc::Error that loading `p` throws ("" if it loads).
std::string load_error(const fs::path& p) {
  try {
    load_map(p, test_support::vocabulary());
  } catch (const Error& e) {
    return e.what();
  }
  return {};
}

bool names_a_table(const std::string& message) {
  for (const char* t :
       {"metadata", "cameras", "keyframes", "keyframe_features", "markers", "map_points",
        "observations", "covisibility", "loop_edges", "gravity_windows", "gyro_links",
        "keyframe_depth", "erased_keyframes", "user_version", "application_id", "sqlite_master"}) {
    if (message.find(t) != std::string::npos) return true;
  }
  return false;
}

class MapDbErrors : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::temp_dir("mapdb_errors");
    good_ = dir_ / "good.db";
    map_ = test::small_map(2, 20);
    save_map(map_, test::test_metadata(), good_);
  }
  fs::path copy(const std::string& name) {
    const fs::path p = dir_ / name;
    fs::copy_file(good_, p, fs::copy_options::overwrite_existing);
    return p;
  }
  // A file of the map's first keyframe and the next (its child) with sound checksums, written
  // through the internal writer: `edit` may change each keyframe's row (which comes without
  // IMU links), `after` add rows once it is written.
  using EditRow = std::function<void(const map::Keyframe&, detail::KeyframeRow&)>;
  using AddRows = std::function<void(const map::Keyframe&, detail::MapWriter&)>;
  void write_pair(const fs::path& p, const EditRow& edit, const AddRows& after = {}) {
    const map::Keyframe& first = *map_.keyframe(map_.first_keyframe());
    const map::Keyframe& second = second_keyframe();
    AtomicFile out(p);
    detail::MapWriter w(out.temp_path(), {}, test::test_metadata());
    detail::EncodedFeatures f;
    for (const map::Keyframe* kf : {&first, &second}) {
      f.encode(kf->id, kf->frame);
      w.features(f);
      detail::KeyframeRow row = detail::KeyframeRow::of(*kf);
      row.parent = kf == &first ? KeyframeId() : first.id;
      row.gyro.reset();
      edit(*kf, row);
      w.keyframe(row);
      if (after) after(*kf, w);
    }
    w.finish(first.id, second.id.value() + 1, 100);
    out.commit(false);
  }
  const map::Keyframe& second_keyframe() const {
    const map::Keyframe* second = nullptr;
    for (const auto& [id, kf] : map_.keyframes()) {
      if (map_.first_keyframe() < id && (!second || id < second->id)) second = &kf;
    }
    return *second;
  }
  fs::path dir_, good_;
  map::Map map_;
};

TEST_F(MapDbErrors, FlippedBytesInAKeyframeBlobNameTheRow) {
  const fs::path p = copy("flipped.db");
  std::vector<char> bytes = read_bytes(p);
  // Find keyframe 7's descriptors in the file by their first 32 bytes, and damage them.
  detail::Bytes encoded;
  detail::encode_descriptor(map_.keyframe(KeyframeId(7))->frame.features.descriptors[0], encoded);
  const std::vector<char> needle(encoded.begin(), encoded.end());
  const auto it = std::search(bytes.begin(), bytes.end(), needle.begin(), needle.end());
  ASSERT_NE(it, bytes.end());
  *(it + 5) = static_cast<char>(*(it + 5) ^ 0x10);
  write_bytes(p, bytes);
  const std::string e = load_error(p);
  EXPECT_NE(e.find(p.string()), std::string::npos) << e;
  EXPECT_NE(e.find("keyframe_features"), std::string::npos) << e;
  EXPECT_NE(e.find("row 7"), std::string::npos) << e;
  const VerifyReport v = verify_map(p);
  ASSERT_FALSE(v.ok());
  EXPECT_NE(v.problems.back().find("keyframe_features"), std::string::npos);
}

TEST_F(MapDbErrors, RandomByteFlipsAreNamedErrorsOrChangeNothing) {
  const std::vector<char> good = read_bytes(good_);
  std::mt19937_64 rng(11);
  int detected = 0;
  for (int trial = 0; trial < 40; ++trial) {
    std::vector<char> bytes = good;
    for (int k = 0; k < 3; ++k) {
      const std::size_t at = rng() % bytes.size();
      bytes[at] = static_cast<char>(bytes[at] ^ static_cast<char>(1 + rng() % 255));
    }
    const fs::path p = dir_ / "random.db";
    write_bytes(p, bytes);
    try {
      const LoadedMap m = load_map(p, test_support::vocabulary());
      // A flip in unused space (free bytes of a page): the map must be exactly the original.
      EXPECT_EQ(map_difference(map_, m.map), "") << "trial " << trial;
    } catch (const Error& e) {
      ++detected;
      EXPECT_NE(std::string(e.what()).find(p.string()), std::string::npos) << e.what();
      EXPECT_TRUE(names_a_table(e.what())) << e.what();
    }
  }
  EXPECT_GT(detected, 10);
}

TEST_F(MapDbErrors, TruncatedFilesAreNamedErrors) {
  const std::vector<char> good = read_bytes(good_);
  for (double fraction : {0.0, 0.01, 0.1, 0.5, 0.9, 0.99}) {
    std::vector<char> bytes(
        good.begin(),
        good.begin() + static_cast<long>(fraction * static_cast<double>(good.size())));
    const fs::path p = dir_ / "truncated.db";
    write_bytes(p, bytes);
    const std::string e = load_error(p);
    EXPECT_NE(e.find(p.string()), std::string::npos) << fraction << ": " << e;
    EXPECT_TRUE(names_a_table(e)) << fraction << ": " << e;
    // Loading never writes: the damaged file is left as it was.
    EXPECT_EQ(read_bytes(p), bytes);
  }
}

TEST_F(MapDbErrors, MissingTableIsNamed) {
  const fs::path p = copy("missing.db");
  sql(p, "DROP TABLE covisibility");
  const std::string e = load_error(p);
  EXPECT_NE(e.find(p.string()), std::string::npos) << e;
  EXPECT_NE(e.find("table 'covisibility' is missing"), std::string::npos) << e;
  // A version-2 file must have the table version 2 added (a version-1 file need not).
  const fs::path no_loops = copy("no_loop_edges.db");
  sql(no_loops, "DROP TABLE loop_edges");
  const std::string l = load_error(no_loops);
  EXPECT_NE(l.find(no_loops.string()), std::string::npos) << l;
  EXPECT_NE(l.find("table 'loop_edges' is missing"), std::string::npos) << l;
  EXPECT_FALSE(verify_map(no_loops).ok());
}

TEST_F(MapDbErrors, NewerSchemaIsRefused) {
  const fs::path p = copy("newer.db");
  sql(p, "PRAGMA user_version = " + std::to_string(kSchemaVersion + 1));
  const std::string e = load_error(p);
  EXPECT_NE(e.find(p.string()), std::string::npos) << e;
  EXPECT_NE(e.find("schema version " + std::to_string(kSchemaVersion + 1) + " is newer"),
            std::string::npos)
      << e;
  EXPECT_THROW(read_map_info(p), Error);
}

TEST_F(MapDbErrors, ForeignVocabularyIsRefused) {
  MapMetadata metadata = test::test_metadata();
  metadata.vocabulary_checksum ^= 0x5a5a;
  const fs::path p = dir_ / "foreign.db";
  save_map(map_, metadata, p);
  const std::string e = load_error(p);
  EXPECT_NE(e.find(p.string()), std::string::npos) << e;
  EXPECT_NE(e.find("metadata.vocabulary_checksum"), std::string::npos) << e;
  EXPECT_NE(e.find("another vocabulary"), std::string::npos) << e;
  EXPECT_FALSE(verify_map(p, &test_support::vocabulary()).ok());
  EXPECT_TRUE(verify_map(p).ok());  // without a vocabulary the file itself is sound
}

TEST_F(MapDbErrors, EditedOrDeletedRowsAreNamed) {
  const fs::path edited = copy("edited.db");
  sql(edited, "UPDATE map_points SET x = x + 1 WHERE id = (SELECT MIN(id) FROM map_points)");
  std::string e = load_error(edited);
  EXPECT_NE(e.find("map_points"), std::string::npos) << e;
  EXPECT_NE(e.find("checksum mismatch"), std::string::npos) << e;
  const fs::path deleted = copy("deleted.db");
  sql(deleted, "DELETE FROM observations WHERE keyframe_id = 3");
  e = load_error(deleted);
  EXPECT_NE(e.find("observations"), std::string::npos) << e;
  EXPECT_NE(e.find("rows where the metadata says"), std::string::npos) << e;
}

// A file with sound checksums but broken references (written through the internal writer):
// the reference checks name the table, column and row.
TEST_F(MapDbErrors, BrokenReferencesNameTableColumnAndRow) {
  const map::Keyframe& kf = *map_.keyframe(map_.first_keyframe());
  auto write = [&](const fs::path& p, const std::vector<MapPointId>& points) {
    AtomicFile out(p);
    detail::MapWriter w(out.temp_path(), {}, test::test_metadata());
    detail::EncodedFeatures f;
    f.encode(kf.id, kf.frame);
    w.features(f);
    w.keyframe(detail::KeyframeRow::of(kf));
    w.observations(kf.id, points);
    w.finish(kf.id, kf.id.value() + 1, 100);
    out.commit(false);
  };
  std::vector<MapPointId> points(kf.frame.size());
  points[5] = MapPointId(42);  // no such point
  const fs::path missing = dir_ / "missing_point.db";
  write(missing, points);
  std::string e = load_error(missing);
  EXPECT_NE(e.find("observations.point_id"), std::string::npos) << e;
  EXPECT_NE(e.find("row (" + std::to_string(kf.id.value()) + ", 5)"), std::string::npos) << e;
  const VerifyReport v = verify_map(missing);
  ASSERT_FALSE(v.ok());
  EXPECT_NE(v.problems.back().find("observations.point_id"), std::string::npos);
}

// Loop edges with sound checksums but a missing reverse row or a missing keyframe (written
// through the internal writer): named by table, column and row.
TEST_F(MapDbErrors, BrokenLoopEdgesNameTableColumnAndRow) {
  const map::Keyframe& first = *map_.keyframe(map_.first_keyframe());
  const map::Keyframe* second = &second_keyframe();
  // Loop edges first -> other, and the reverse one when `both_sides`.
  auto write = [&](const fs::path& p, KeyframeId other, bool both_sides) {
    write_pair(
        p, [](const map::Keyframe&, detail::KeyframeRow&) {},
        [&](const map::Keyframe& kf, detail::MapWriter& w) {
          if (&kf == &first) w.loop_edges(kf.id, std::set<KeyframeId>{other});
          if (&kf == second && both_sides) w.loop_edges(kf.id, std::set<KeyframeId>{first.id});
        });
  };
  const std::string row = "row (" + std::to_string(first.id.value()) + ", ";

  const fs::path good = dir_ / "loop_good.db";
  write(good, second->id, true);
  const LoadedMap loaded = load_map(good, test_support::vocabulary());
  EXPECT_EQ(loaded.map.keyframe(first.id)->loop_edges, std::set<KeyframeId>{second->id});
  EXPECT_EQ(loaded.map.keyframe(second->id)->loop_edges, std::set<KeyframeId>{first.id});
  EXPECT_EQ(read_map_info(good).counts.loop_edges, 2u);

  const fs::path one_sided = dir_ / "loop_one_sided.db";
  write(one_sided, second->id, false);
  std::string e = load_error(one_sided);
  EXPECT_NE(e.find(one_sided.string()), std::string::npos) << e;
  EXPECT_NE(e.find("loop_edges.other_id"), std::string::npos) << e;
  EXPECT_NE(e.find(row + std::to_string(second->id.value()) + ")"), std::string::npos) << e;
  EXPECT_NE(e.find("no reverse row"), std::string::npos) << e;
  VerifyReport v = verify_map(one_sided);
  ASSERT_FALSE(v.ok());
  EXPECT_NE(v.problems.back().find("loop_edges.other_id"), std::string::npos);

  const fs::path missing = dir_ / "loop_missing.db";
  write(missing, KeyframeId(999), false);
  e = load_error(missing);
  EXPECT_NE(e.find(missing.string()), std::string::npos) << e;
  EXPECT_NE(e.find("loop_edges.other_id"), std::string::npos) << e;
  EXPECT_NE(e.find(row + "999)"), std::string::npos) << e;
  EXPECT_NE(e.find("no such other keyframe"), std::string::npos) << e;
  v = verify_map(missing);
  ASSERT_FALSE(v.ok());
  EXPECT_NE(v.problems.back().find("loop_edges.other_id"), std::string::npos);
}

// The IMU's rows with sound checksums but a link to a missing keyframe or a recording that
// starts after its keyframe: named by table, column and row; a sound link loads.
TEST_F(MapDbErrors, BrokenGyroLinksNameTableColumnAndRow) {
  const map::Keyframe& first = *map_.keyframe(map_.first_keyframe());
  const map::Keyframe& second = second_keyframe();
  ASSERT_TRUE(first.gyro && first.gravity);
  auto write = [&](const fs::path& p, KeyframeId next, KeyframeId recording) {
    write_pair(p, [&](const map::Keyframe& kf, detail::KeyframeRow& row) {
      if (&kf != &first) return;
      row.gyro = *first.gyro;
      row.gyro->next = next;
      row.gravity->recording = recording;
    });
  };
  const fs::path good = dir_ / "gyro_good.db";
  write(good, second.id, first.id);
  const LoadedMap loaded = load_map(good, test_support::vocabulary());
  ASSERT_TRUE(loaded.map.keyframe(first.id)->gyro);
  EXPECT_EQ(loaded.map.keyframe(first.id)->gyro->next, second.id);
  EXPECT_EQ(read_map_info(good).counts.gyro_links, 1u);

  const std::string row = "row " + std::to_string(first.id.value());
  const fs::path missing = dir_ / "gyro_missing.db";
  write(missing, KeyframeId(999), first.id);
  std::string e = load_error(missing);
  EXPECT_NE(e.find(missing.string()), std::string::npos) << e;
  EXPECT_NE(e.find("gyro_links.next_id"), std::string::npos) << e;
  EXPECT_NE(e.find(row), std::string::npos) << e;
  const VerifyReport v = verify_map(missing);
  ASSERT_FALSE(v.ok());
  EXPECT_NE(v.problems.back().find("gyro_links.next_id"), std::string::npos);

  const fs::path late = dir_ / "gravity_late.db";
  write(late, second.id, second.id);
  e = load_error(late);
  EXPECT_NE(e.find("gravity_windows.recording"), std::string::npos) << e;
  EXPECT_NE(e.find(row), std::string::npos) << e;
}

// Damaged keyframe_depth rows (edited in the shell): each is an error naming the file, the
// column and the keyframe, from load and verify alike, never a crash or a huge allocation.
TEST_F(MapDbErrors, BrokenKeyframeDepthNamesTableColumnAndRow) {
  KeyframeId with_depth;
  for (const auto& [id, kf] : map_.keyframes()) {
    if (kf.depth && id != map_.first_keyframe() && (!with_depth.valid() || id < with_depth))
      with_depth = id;
  }
  ASSERT_TRUE(with_depth.valid());
  const std::string id = std::to_string(with_depth.value());
  const std::string where = " WHERE keyframe_id = " + id;
  struct Case {
    const char* name;
    std::string edit;
    const char* column;
  };
  const std::vector<Case> cases = {
      {"short", "UPDATE keyframe_depth SET depth = substr(depth, 1, 10)" + where, "depth"},
      {"odd", "UPDATE keyframe_depth SET depth = depth || X'00'" + where, "depth"},
      {"zero_width", "UPDATE keyframe_depth SET width = 0" + where, "width"},
      {"huge", "UPDATE keyframe_depth SET width = 1000000, height = 1000000" + where, "width"},
      {"negative", "UPDATE keyframe_depth SET height = -80" + where, "height"},
      {"factor_zero", "UPDATE keyframe_depth SET factor = 0" + where, "factor"},
      {"larger_than_image", "UPDATE keyframe_depth SET factor = 16" + where, "width"},
      {"flipped", "UPDATE keyframe_depth SET depth = zeroblob(length(depth))" + where, "checksum"},
      {"orphan", "UPDATE keyframe_depth SET keyframe_id = 999" + where, "keyframe_id"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const fs::path p = copy(std::string("depth_") + c.name + ".db");
    sql(p, c.edit);
    const std::string e = load_error(p);
    EXPECT_NE(e.find(p.string()), std::string::npos) << e;
    EXPECT_NE(e.find(std::string("keyframe_depth.") + c.column), std::string::npos) << e;
    EXPECT_NE(e.find("row " + (std::string(c.name) == "orphan" ? "999" : id)), std::string::npos)
        << e;
    const VerifyReport v = verify_map(p);
    ASSERT_FALSE(v.ok());
    EXPECT_NE(v.problems.back().find(std::string("keyframe_depth.") + c.column), std::string::npos)
        << v.problems.back();
  }
  // A whole row deleted: the table's count says so.
  const fs::path deleted = copy("depth_deleted.db");
  sql(deleted, "DELETE FROM keyframe_depth" + where);
  const std::string e = load_error(deleted);
  EXPECT_NE(e.find("keyframe_depth"), std::string::npos) << e;
  EXPECT_NE(e.find("rows where the metadata says"), std::string::npos) << e;
}

// A depth image that fails its check is refused by the save, naming the table and keyframe;
// the previous file stays.
TEST_F(MapDbErrors, InvalidKeyframeDepthIsNotSaved) {
  map::Map broken = map_;
  KeyframeId id;
  broken.for_each_keyframe([&](map::Keyframe& kf) {
    if (!id.valid() && kf.depth) {
      kf.depth->millimetres.pop_back();
      id = kf.id;
    }
  });
  ASSERT_TRUE(id.valid());
  const std::vector<char> before = read_bytes(good_);
  try {
    save_map(broken, test::test_metadata(), good_);
    ADD_FAILURE() << "saved";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("keyframe_depth"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("keyframe " + std::to_string(id.value())),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(read_bytes(good_), before);
}

TEST_F(MapDbErrors, FailedSaveKeepsThePreviousFile) {
  const map::Map other = test::small_map(9, 25);
  SaveOptions options;
  int calls = 0;
  options.progress = [&](std::uint64_t, std::uint64_t) {
    if (++calls == 2) throw Error("cancelled");
  };
  EXPECT_THROW(save_map(other, test::test_metadata(), good_, options), Error);
  EXPECT_EQ(map_difference(map_, load_map(good_, test_support::vocabulary()).map), "");
  for (const auto& entry : fs::directory_iterator(dir_))
    EXPECT_EQ(entry.path().string().find(".tmp-"), std::string::npos) << entry.path();
}

TEST_F(MapDbErrors, UnwritableOutputIsAnErrorBeforeAnyWork) {
  bool worked = false;
  SaveOptions options;
  options.progress = [&](std::uint64_t, std::uint64_t) { worked = true; };
  const fs::path nowhere = dir_ / "no_such_dir" / "map.db";
  try {
    save_map(map_, test::test_metadata(), nowhere, options);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(nowhere.string()), std::string::npos) << e.what();
  }
  EXPECT_THROW(save_map(map_, test::test_metadata(), good_ / "x.db", options), Error);
  EXPECT_THROW(save_map(map_, test::test_metadata(), dir_, options), Error);  // a directory
  if (::geteuid() != 0) {  // root writes into read-only directories
    const fs::path ro = dir_ / "read_only";
    fs::create_directory(ro);
    ::chmod(ro.c_str(), 0555);
    EXPECT_THROW(save_map(map_, test::test_metadata(), ro / "map.db", options), Error);
    ::chmod(ro.c_str(), 0755);
  }
  EXPECT_FALSE(worked);
}

TEST(AtomicFile, ReplacesOnCommitOnly) {
  const fs::path dir = testing::temp_dir("atomic_file");
  const fs::path target = dir / "out.txt";
  std::ofstream(target) << "old";
  {
    AtomicFile f(target);
    std::ofstream(f.temp_path()) << "new";
  }  // no commit
  EXPECT_EQ(read_bytes(target), std::vector<char>({'o', 'l', 'd'}));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);
  {
    AtomicFile f(target);
    std::ofstream(f.temp_path()) << "new";
    f.commit();
  }
  EXPECT_EQ(read_bytes(target), std::vector<char>({'n', 'e', 'w'}));
  // Leftovers of dead processes go; those of running ones (pid 1) stay.
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  ASSERT_GT(child, 0);
  ::waitpid(child, nullptr, 0);
  const fs::path dead = dir / ("out.txt.tmp-" + std::to_string(child));
  const fs::path alive = dir / "out.txt.tmp-1";
  std::ofstream(dead) << "x";
  std::ofstream(alive) << "x";
  AtomicFile::remove_stale(target);
  EXPECT_FALSE(fs::exists(dead));
  EXPECT_TRUE(fs::exists(alive));
}

TEST(MapRestore, RejectsBrokenRelations) {
  const map::Map good = test::small_map(4, 8);
  auto restore = [&](auto edit) {
    std::unordered_map<KeyframeId, map::Keyframe> kfs = good.keyframes();
    std::unordered_map<MapPointId, map::MapPoint> pts = good.points();
    map::MapBookkeeping b = good.bookkeeping();
    edit(kfs, pts, b);
    return map::Map::restore(std::move(kfs), std::move(pts), std::move(b));
  };
  EXPECT_EQ(map_difference(good, restore([](auto&, auto&, auto&) {})), "");
  // One side of an observation missing.
  EXPECT_THROW(restore([](auto& kfs, auto&, auto&) {
                 for (auto& [id, kf] : kfs)
                   std::fill(kf.frame.points.begin(), kf.frame.points.end(), MapPointId::invalid());
               }),
               Error);
  // A spanning-tree cycle between two keyframes.
  EXPECT_THROW(restore([](auto& kfs, auto&, auto& b) {
                 KeyframeId a, c;
                 for (const auto& [id, kf] : kfs) {
                   if (id == b.first_keyframe) continue;
                   (a.valid() ? c : a) = id;
                 }
                 kfs.at(a).parent = c;
                 kfs.at(c).parent = a;
               }),
               Error);
  // An id the issuer has not issued yet.
  EXPECT_THROW(restore([](auto&, auto&, auto& b) { b.next_point_id = 1; }), Error);
}

}  // namespace
}  // namespace coloc::slam::mapdb
