#pragma once
// The map database: a SLAM map (slam/map) as one SQLite file, readable with the sqlite3 shell.
// Schema, blob layouts and example queries: README, "Map database".
//
// Saving writes a new file `<MAP.db>.tmp-<pid>` next to the target in one transaction, flushes
// it, and renames it over the target (AtomicFile): a crash or kill -9 at any moment leaves the
// previous map loadable, and a failed save never replaces it. Rows are streamed through
// prepared statements with a small SQLite page cache, so memory stays bounded whatever the map
// size (no image of the file is built in memory).
//
// Loading checks the schema version, every table, every blob size, every reference
// (observations, covisibility, loop edges, spanning tree, erased-keyframe chain), the content
// checksums and the vocabulary, then rebuilds what is derived: frame grids, children and
// covisibility order, BoW vectors and the BoW database. A map saved and loaded equals the original
// field by field. Every problem is a coloc::Error naming the file and the table (field
// "table.column") and row; loading never writes.
//
// Thread-safety: functions are independent (one SQLite connection each). save_map() reads the
// Map without locking: the caller keeps it unchanged meanwhile. save_live_map() is for a Map
// that other threads keep changing (see there).
#include <cstdint>
#include <filesystem>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "slam/bow/database.hpp"
#include "slam/bow/vocabulary.hpp"
#include "slam/core/camera.hpp"
#include "slam/core/sim3.hpp"
#include "slam/core/trajectory.hpp"
#include "slam/frame/frame.hpp"
#include "slam/map/map.hpp"

namespace coloc::slam::mapdb {

// PRAGMA user_version of the files this build writes; it reads this version and older ones
// (version 1 has no `loop_edges` table: such a map loads without loop edges; before version 4
// keyframes have no depth images).
constexpr int kSchemaVersion = 4;

// What a map file says about itself (table `metadata`).
struct MapMetadata {
  std::string coloc_version;  // of the build that saved it (save_map fills it in)
  std::string saved_utc;      // ISO 8601 time of the save (save_map fills it in)
  // vocabulary_checksum() of the vocabulary the keyframes' BoW vectors come from; a map only
  // loads with that vocabulary.
  std::uint64_t vocabulary_checksum = 0;
  std::uint32_t vocabulary_words = 0;
  std::string settings;  // the settings used to build the map (free text, e.g. the YAML)
  // The frame the map's world coordinates are in: "slam" until registration puts the map into
  // another frame (e.g. "scan") and says so here.
  std::string frame_name = "slam";
  // Registration's transform: maps points of the SLAM frame into `frame_name`, if any.
  std::optional<Sim3> frame_from_slam;
  // What registration did (`coloc register`: level, transform, per-level residuals) as one JSON
  // document; empty for a map that was never registered. Entry `registration`, written only
  // when not empty (maps without it load as before).
  std::string registration;
  // Seconds: the rolling-shutter readout estimated while mapping (settings without
  // Camera.readoutTime), for localization with the same settings. Entry `estimated_readout`,
  // written only when set.
  std::optional<double> estimated_readout;
  // The camera model (with distortion) the keyframes' undistorted keypoints came from. Saved in
  // every `cameras` row; read back from the first one.
  std::optional<Camera> camera;
};

// The FNV-1a checksum the vocabulary file ends with (bow/vocabulary.hpp), identical for the
// same vocabulary wherever it is loaded from. Serializes the vocabulary once: call it once.
std::uint64_t vocabulary_checksum(const bow::Vocabulary& vocabulary);

// (rows done, rows total) of a save or load; may throw to cancel: a cancelled save leaves the
// previous file in place.
using ProgressFn = std::function<void(std::uint64_t done, std::uint64_t total)>;

struct SaveOptions {
  int cache_mib = 8;                // SQLite page cache while writing: the bound on its memory
  int page_size = 8192;             // bytes, SQLite page size of the new file (512..65536, 2^k)
  std::size_t chunk_keyframes = 4;  // save_live_map: keyframes whose features one lock copies
  // fsync the file and its directory (turn off only to measure the writing itself).
  bool sync = true;
  ProgressFn progress;
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

struct SaveReport {
  std::size_t keyframes = 0, points = 0, observations = 0, markers = 0;
  std::uint64_t bytes = 0;  // file size
  double seconds = 0.0;
  // save_live_map only: how often and how long the caller's mutex was held, and the keyframes
  // created (features copied with the snapshot) or erased (features dropped) meanwhile.
  std::size_t locks = 0;
  double max_lock_ms = 0.0, total_lock_ms = 0.0;
  std::size_t late_keyframes = 0, dropped_keyframes = 0;
};

// Saves a Map that does not change during the call (after System::shutdown(), or a map owned by
// the caller's thread). Throws coloc::Error naming the file; the previous file is then intact.
SaveReport save_map(const map::Map& map, const MapMetadata& metadata,
                    const std::filesystem::path& path, const SaveOptions& options = {});

// Saves a Map that other threads keep changing under `mutex` (SharedMap in slam/map): tracking
// is never held up for more than a short copy. The mutex is taken briefly and repeatedly:
//  1. keyframe features (keypoints, descriptors, depth, u_right) and depth images (by far the
//     largest part, and never changed once a keyframe is in the Map) are copied a few keyframes per
//     lock and written without the lock;
//  2. one lock copies the rest, which is small (poses, tree, covisibility, loop edges,
//     keypoint -> point lists, markers, map points without their observation maps) and the
//     features of keyframes created meanwhile: the snapshot, consistent as of this moment;
//  3. the snapshot is written without the lock, and features of keyframes erased since step 1
//     are dropped. The file holds the map exactly as it was at step 2.
SaveReport save_live_map(const map::Map& map, std::mutex& mutex, const MapMetadata& metadata,
                         const std::filesystem::path& path, const SaveOptions& options = {});

struct LoadOptions {
  int cache_mib = 8;        // SQLite page cache while reading
  bool rebuild_bow = true;  // BoW vectors and database (the vocabulary's transform per keyframe)
  int threads = 0;          // for the BoW vectors, the slowest part (0: one per core)
  // The keyframes' small depth images (schema 4; about 38 KB a keyframe). A localizer needs
  // none of them, so it leaves them in the file (and unchecked); a map loaded without them must
  // not be saved over one that has them.
  bool keyframe_depth = true;
  // Each keyframe's BoW vector (frame.bow), when rebuild_bow makes them. Loop closing and local
  // mapping read it; tracking and relocalization never do (they query `database`, which holds the
  // same weights in its index), so a localizer drops it after the database has it: about 16 bytes a
  // word, some 1,000 words a keyframe. Each keyframe keeps its feature vector, which matching
  // reads, either way.
  bool keyframe_bow = true;
  // Each keyframe's per-keypoint depth and virtual right coordinate and its keypoint grid
  // (frame::Frame::drop_search_data): what mapping, loop closing and registration read when
  // they search in a keyframe's image or weigh its observations. Tracking and relocalization
  // match a frame against a keyframe by BoW and through the keyframe's points only (keypoint
  // angles, descriptors, feature vector, points), so a localizer drops them: ~24 kB a keyframe.
  bool keyframe_search = true;
  ProgressFn progress;
  void check() const;
};

struct LoadedMap {
  map::Map map;
  MapMetadata metadata;
  bow::BowDatabase database;  // image key = keyframe id value, as SharedMap::database
  // One per `cameras` row, shared by the keyframes' frames.
  std::vector<std::shared_ptr<const frame::FrameGeometry>> geometries;
};

// The camera model a loaded map's keyframes came from: the metadata's, else (maps saved before
// the model was stored) a pinhole with the keyframes' intrinsics. Throws coloc::Error naming
// `file` when the map has no camera at all.
Camera camera_of(const LoadedMap& map, const std::filesystem::path& file);

// Throws coloc::Error naming the file and table/row for a missing, truncated or damaged file, a
// missing table, a newer schema, a map made with another vocabulary, or any broken reference.
LoadedMap load_map(const std::filesystem::path& path, const bow::Vocabulary& vocabulary,
                   const LoadOptions& options = {});

struct MapCounts {
  std::uint64_t keyframes = 0, points = 0, observations = 0, markers = 0, covisibility = 0,
                erased_keyframes = 0, cameras = 0;
  std::uint64_t loop_edges = 0;  // rows, one per direction (0 in a schema-1 file)
  std::uint64_t gravity_windows = 0, gyro_links = 0;  // 0 before schema 3
  std::uint64_t keyframe_depths = 0;                  // 0 before schema 4
};

struct MapInfo {
  int schema_version = 0;
  MapMetadata metadata;
  MapCounts counts;  // as the metadata states them
  std::uint64_t file_bytes = 0;
};

// The metadata only (fast): checks that the file is a coloc map of a readable schema version
// with every table present. Throws coloc::Error like load_map().
MapInfo read_map_info(const std::filesystem::path& path);

struct VerifyReport {
  MapInfo info;
  std::vector<std::string> problems;  // each names the table and row; empty when the map is good
  bool ok() const { return problems.empty(); }
};

// PRAGMA integrity_check, then a full load without BoW (every check load_map() makes); with a
// vocabulary also its checksum. Problems are reported (each naming the file and table/row),
// never thrown; a missing or foreign file is a problem too.
VerifyReport verify_map(const std::filesystem::path& path,
                        const bow::Vocabulary* vocabulary = nullptr,
                        const ProgressFn& progress = {});

// The keyframes' world_from_cam by timestamp (TUM trajectory), read without loading the map.
Trajectory read_keyframe_trajectory(const std::filesystem::path& path);

struct PointRecord {
  MapPointId id;
  Eigen::Vector3d position;  // world (the metadata's frame), metres
  Eigen::Vector3d normal;    // mean viewing direction, unit
  std::uint32_t observations = 0;
};

// Streams the map points in id order (for exports), without loading the map.
void for_each_point(const std::filesystem::path& path,
                    const std::function<void(const PointRecord&)>& visit);

}  // namespace coloc::slam::mapdb
