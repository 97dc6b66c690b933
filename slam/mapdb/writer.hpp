#pragma once
// Writing a map file row by row (internal to slam/mapdb): save_map() feeds it straight from a
// Map, save_live_map() from a snapshot. Rows of each table arrive in primary-key order, so the
// B-trees only grow at their right edge and the content checksums can be folded as they go.
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <span>
#include <unordered_map>
#include <vector>

#include "slam/mapdb/codec.hpp"
#include "slam/mapdb/mapdb.hpp"
#include "slam/mapdb/sqlite.hpp"

namespace coloc::slam::mapdb::detail {

// The `keyframes` row of a keyframe, with its `gravity_windows` and `gyro_links` rows:
// everything but its features, markers and relations.
struct KeyframeRow {
  KeyframeId id;
  FrameId frame_id;
  double timestamp = 0.0;
  SE3 cam_from_world;
  bool has_pose = false;
  KeyframeId parent;
  int image_width = 0, image_height = 0;
  std::uint32_t keypoint_count = 0;
  double marker_size = 0.0;
  std::shared_ptr<const frame::FrameGeometry> geometry;
  std::optional<map::GravityWindow> gravity;
  std::optional<map::GyroLink> gyro;

  static KeyframeRow of(const map::Keyframe& kf);
};

// The `map_points` row of a point (its observations are the keyframes' side).
struct PointRow {
  MapPointId id;
  Eigen::Vector3d position;
  features::Descriptor descriptor;
  Eigen::Vector3d normal;
  double min_distance = 0.0, max_distance = 0.0;
  KeyframeId reference, first_keyframe;
  int visible = 0, found = 0;

  static PointRow of(const map::MapPoint& p);
};

// A keyframe's features, encoded (blobs of codec.hpp).
struct EncodedFeatures {
  KeyframeId id;
  Bytes keypoints, descriptors;
  void encode(KeyframeId keyframe, const frame::Frame& frame);
};

class MapWriter {
 public:
  // Opens `file` (an empty temporary) and creates the schema inside one open transaction.
  MapWriter(const std::filesystem::path& file, const SaveOptions& options,
            const MapMetadata& metadata);

  // keyframe_features rows may come ahead of their keyframes (save_live_map) and be dropped.
  void features(const EncodedFeatures& features);
  // Deletes the features (and depth) rows of keyframes not in `keyframes` (sorted): erased
  // meanwhile. Returns how many keyframes' features were dropped.
  std::size_t drop_features_except(const std::vector<KeyframeId>& keyframes);
  bool has_features(KeyframeId keyframe) const { return feature_hashes_.count(keyframe) > 0; }
  // The keyframe's keyframe_depth row: written with its features (never changed once the
  // keyframe is in the Map), so like them it may come ahead of its keyframe and be dropped by
  // drop_features_except(). Throws if `depth` fails its check().
  void depth(KeyframeId keyframe, const map::KeyframeDepth& depth);
  // The keyframes row, and the keyframe's gravity_windows and gyro_links rows if it has them.
  void keyframe(const KeyframeRow& row);
  void markers(KeyframeId keyframe, std::span<const markers::MarkerObservation> observations);
  // The keyframe's keypoint -> point list (frame.points; invalid ids are skipped), or the valid
  // entries only, as parallel arrays (save_live_map's snapshot).
  void observations(KeyframeId keyframe, std::span<const MapPointId> points);
  void observations(KeyframeId keyframe, std::span<const std::uint32_t> keypoints,
                    std::span<const MapPointId> points);
  void covisibility(KeyframeId keyframe, const std::map<KeyframeId, int>& edges);
  void covisibility(KeyframeId keyframe, std::span<const std::pair<KeyframeId, int>> edges);
  // The keyframe's loop edges, in increasing order of the other id (one row per direction: the
  // other keyframe writes the reverse row).
  void loop_edges(KeyframeId keyframe, std::span<const KeyframeId> others);
  void loop_edges(KeyframeId keyframe, const std::set<KeyframeId>& others);
  void point(const PointRow& row);
  void erased(KeyframeId keyframe, const map::ErasedKeyframe& erased);
  // Writes the metadata (with counts and checksums), commits and closes the file. Throws if a
  // keyframe has no features row or the features or depth of a missing keyframe remain.
  void finish(KeyframeId first_keyframe, std::uint64_t next_keyframe_id,
              std::uint64_t next_point_id);

  const MapCounts& counts() const { return counts_; }

 private:
  struct Table {
    Table(Database& db, const std::string& name);
    Statement insert;
    ContentHash hash;  // fold of the row hashes, in key order
    std::uint64_t rows = 0;
  };
  std::int64_t camera_id(const std::shared_ptr<const frame::FrameGeometry>& geometry);
  // Starts a row: the row's values are hashed as they are bound.
  Statement& begin_row(Table& t);
  void end_row(Table& t);
  void observation(KeyframeId keyframe, std::uint32_t keypoint, MapPointId point);
  void edge(KeyframeId keyframe, KeyframeId other, int weight);
  void loop_edge(KeyframeId keyframe, KeyframeId other);
  void gravity(KeyframeId keyframe, const map::GravityWindow& g);
  void gyro(KeyframeId keyframe, const map::GyroLink& g);

  Database db_;
  MapMetadata metadata_;
  ContentHash row_hash_;
  std::map<std::string, Table> tables_;
  std::unique_ptr<Statement> delete_features_, delete_depth_;
  std::unordered_map<const frame::FrameGeometry*, std::int64_t> camera_ids_;
  std::vector<std::shared_ptr<const frame::FrameGeometry>> cameras_;  // kept alive
  std::map<KeyframeId, std::uint64_t> feature_hashes_;                // row hash per features row
  std::map<KeyframeId, std::uint64_t> depth_hashes_;                  // and per depth row
  std::vector<KeyframeId> keyframe_ids_;
  Bytes pose_, descriptor_, depth_;
  MapCounts counts_;
};

// ISO 8601 UTC time now, e.g. "2024-05-01T12:00:00Z".
std::string utc_now();

}  // namespace coloc::slam::mapdb::detail
