#include "slam/mapdb/writer.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <variant>

#include "slam/core/error.hpp"
#include "slam/mapdb/metadata.hpp"
#include "slam/mapdb/schema.hpp"

namespace coloc::slam::mapdb::detail {

namespace {

// Ids as SQLite INTEGERs; an invalid id is NULL.
template <typename IdType>
void bind_id(Statement& s, IdType id) {
  if (id.valid()) {
    s.integer(static_cast<std::int64_t>(id.value()));
  } else {
    s.null();
  }
}

std::vector<double> distortion_of(const Camera& camera) {
  return std::visit(
      [](const auto& c) { return std::vector<double>(c.distortion.begin(), c.distortion.end()); },
      camera);
}

// Deletes (through `remove`, bound by keyframe id) the rows of the keyframes not in `kept`
// (sorted) and forgets their hashes; returns how many went.
std::size_t drop_rows_except(std::map<KeyframeId, std::uint64_t>& hashes, Statement& remove,
                             const std::vector<KeyframeId>& kept) {
  std::size_t dropped = 0;
  for (auto it = hashes.begin(); it != hashes.end();) {
    if (std::binary_search(kept.begin(), kept.end(), it->first)) {
      ++it;
      continue;
    }
    remove.integer(static_cast<std::int64_t>(it->first.value()));
    remove.run();
    it = hashes.erase(it);
    ++dropped;
  }
  return dropped;
}

}  // namespace

KeyframeRow KeyframeRow::of(const map::Keyframe& kf) {
  const frame::Frame& f = kf.frame;
  return {kf.id,
          f.id,
          f.timestamp,
          f.cam_from_world,
          f.has_pose,
          kf.parent,
          f.features.image_width,
          f.features.image_height,
          static_cast<std::uint32_t>(f.size()),
          kf.marker_size,
          f.geometry_ptr(),
          kf.gravity,
          kf.gyro};
}

PointRow PointRow::of(const map::MapPoint& p) {
  return {p.id,           p.position,  p.descriptor,     p.normal,  p.min_distance,
          p.max_distance, p.reference, p.first_keyframe, p.visible, p.found};
}

void EncodedFeatures::encode(KeyframeId keyframe, const frame::Frame& frame) {
  id = keyframe;
  encode_keypoints(frame.features.keypoints, frame.depth, frame.u_right, frame.outlier, keypoints);
  encode_descriptors(frame.features.descriptors, descriptors);
}

MapWriter::Table::Table(Database& db, const std::string& name)
    : insert(db, insert_sql(table(name)), name) {}

MapWriter::MapWriter(const std::filesystem::path& file, const SaveOptions& options,
                     const MapMetadata& metadata)
    : db_(file, Database::Mode::kCreate), metadata_(metadata) {
  // A fresh file renamed into place only when complete: no rollback journal is needed, and
  // syncing happens once at the end (AtomicFile). The small cache bounds SQLite's memory;
  // dirty pages beyond it spill into the file.
  db_.exec("PRAGMA page_size = " + std::to_string(options.page_size));
  db_.exec("PRAGMA journal_mode = OFF");
  db_.exec("PRAGMA synchronous = OFF");
  db_.exec("PRAGMA locking_mode = EXCLUSIVE");
  db_.exec("PRAGMA cache_size = -" + std::to_string(options.cache_mib * 1024));
  db_.exec("PRAGMA application_id = " + std::to_string(kApplicationId));
  db_.exec("PRAGMA user_version = " + std::to_string(kSchemaVersion));
  db_.exec("BEGIN");
  for (const TableSchema& t : tables()) {
    db_.exec(t.create, t.name);
    tables_.try_emplace(t.name, db_, t.name);
  }
  delete_features_ = std::make_unique<Statement>(
      db_, "DELETE FROM keyframe_features WHERE keyframe_id = ?", "keyframe_features");
  delete_depth_ = std::make_unique<Statement>(
      db_, "DELETE FROM keyframe_depth WHERE keyframe_id = ?", "keyframe_depth");
}

Statement& MapWriter::begin_row(Table& t) {
  row_hash_ = ContentHash();
  t.insert.attach(&row_hash_);
  return t.insert;
}

void MapWriter::end_row(Table& t) {
  t.insert.run();
  t.insert.attach(nullptr);
  t.hash.fold(row_hash_.value());
  ++t.rows;
}

std::int64_t MapWriter::camera_id(const std::shared_ptr<const frame::FrameGeometry>& geometry) {
  if (!geometry) throw Error("save_map: a keyframe has no frame geometry");
  auto it = camera_ids_.find(geometry.get());
  if (it != camera_ids_.end()) return it->second;
  const auto id = static_cast<std::int64_t>(cameras_.size());
  const frame::FrameGeometry& g = *geometry;
  const std::optional<Camera>& camera = metadata_.camera;
  if (camera) {
    const Eigen::Matrix3d k = intrinsic_matrix(*camera);
    if (k(0, 0) != g.fx || k(1, 1) != g.fy || k(0, 2) != g.cx || k(1, 2) != g.cy)
      throw Error("save_map: the metadata's camera has other intrinsics than the keyframes'",
                  {.field = "cameras.fx"});
  }
  Table& t = tables_.at("cameras");
  Statement& s = begin_row(t);
  s.integer(id).text(camera ? model_name(*camera) : "none");
  s.integer(camera ? image_width(*camera) : 0).integer(camera ? image_height(*camera) : 0);
  s.real(g.fx).real(g.fy).real(g.cx).real(g.cy);
  Bytes distortion, scales;
  const std::vector<double> d = camera ? distortion_of(*camera) : std::vector<double>{};
  encode_f64s(d, distortion);
  encode_f32s(g.scale_factors, scales);
  s.blob(distortion).real(g.bf).real(g.close_depth).real(g.min_depth).real(g.max_depth);
  s.real(g.readout).real(g.min_x).real(g.max_x).real(g.min_y).real(g.max_y);
  s.integer(g.grid_cols).integer(g.grid_rows).blob(scales);
  end_row(t);
  camera_ids_[geometry.get()] = id;
  cameras_.push_back(geometry);
  ++counts_.cameras;
  return id;
}

void MapWriter::features(const EncodedFeatures& f) {
  // The row's own checksum covers id and blobs, so a damaged blob is named by its row.
  ContentHash own;
  own.integer(static_cast<std::int64_t>(f.id.value()));
  own.blob(f.keypoints);
  own.blob(f.descriptors);
  Table& t = tables_.at("keyframe_features");
  Statement& s = begin_row(t);
  s.integer(static_cast<std::int64_t>(f.id.value())).blob(f.keypoints).blob(f.descriptors);
  s.integer(static_cast<std::int64_t>(own.value()));
  t.insert.run();
  t.insert.attach(nullptr);
  // Folded into the table's checksum at finish(), over the rows that remain.
  feature_hashes_[f.id] = row_hash_.value();
}

void MapWriter::depth(KeyframeId keyframe, const map::KeyframeDepth& d) {
  try {
    d.check();
  } catch (const Error& e) {
    throw Error("save_map: keyframe " + std::to_string(keyframe.value()) + ": " + e.message(),
                {.file = db_.path().string(), .field = "keyframe_depth"});
  }
  encode_u16s(d.millimetres, depth_);
  // As for features: the row's own checksum names a damaged blob by its row.
  const auto id = static_cast<std::int64_t>(keyframe.value());
  ContentHash own;
  own.integer(id);
  own.integer(d.width);
  own.integer(d.height);
  own.integer(d.factor);
  own.blob(depth_);
  Table& t = tables_.at("keyframe_depth");
  Statement& s = begin_row(t);
  s.integer(id).integer(d.width).integer(d.height).integer(d.factor).blob(depth_);
  s.integer(static_cast<std::int64_t>(own.value()));
  t.insert.run();
  t.insert.attach(nullptr);
  // Folded into the table's checksum at finish(), over the rows that remain.
  depth_hashes_[keyframe] = row_hash_.value();
}

std::size_t MapWriter::drop_features_except(const std::vector<KeyframeId>& keyframes) {
  drop_rows_except(depth_hashes_, *delete_depth_, keyframes);
  return drop_rows_except(feature_hashes_, *delete_features_, keyframes);
}

void MapWriter::keyframe(const KeyframeRow& r) {
  const std::int64_t camera = camera_id(r.geometry);
  Table& t = tables_.at("keyframes");
  Statement& s = begin_row(t);
  s.integer(static_cast<std::int64_t>(r.id.value()));
  bind_id(s, r.frame_id);
  s.real(r.timestamp).integer(camera);
  // world_from_cam as columns, for readers of the file (trajectory export by SQL); the blob
  // holds the cam_from_world the map uses, bit for bit.
  const SE3 world_from_cam = r.cam_from_world.inverse();
  const Eigen::Vector3d& p = world_from_cam.translation();
  const Eigen::Quaterniond& q = world_from_cam.quaternion();
  s.real(p.x()).real(p.y()).real(p.z()).real(q.x()).real(q.y()).real(q.z()).real(q.w());
  encode_pose(r.cam_from_world, pose_);
  s.blob(pose_).integer(r.has_pose ? 1 : 0);
  bind_id(s, r.parent);
  s.integer(r.image_width).integer(r.image_height).integer(r.keypoint_count).real(r.marker_size);
  end_row(t);
  keyframe_ids_.push_back(r.id);
  ++counts_.keyframes;
  if (r.gravity) gravity(r.id, *r.gravity);
  if (r.gyro) gyro(r.id, *r.gyro);
}

void MapWriter::gravity(KeyframeId keyframe, const map::GravityWindow& g) {
  Table& t = tables_.at("gravity_windows");
  Statement& s = begin_row(t);
  s.integer(static_cast<std::int64_t>(keyframe.value()));
  s.integer(static_cast<std::int64_t>(g.recording.value()));
  for (const Eigen::Vector3d* v : {&g.specific_force_cam, &g.accel_world})
    s.real(v->x()).real(v->y()).real(v->z());
  end_row(t);
  ++counts_.gravity_windows;
}

void MapWriter::gyro(KeyframeId keyframe, const map::GyroLink& g) {
  Table& t = tables_.at("gyro_links");
  Statement& s = begin_row(t);
  s.integer(static_cast<std::int64_t>(keyframe.value()));
  s.integer(static_cast<std::int64_t>(g.recording.value()));
  s.integer(static_cast<std::int64_t>(g.next.value()));
  const Eigen::Quaterniond& q = g.cam_from_next.quaternion();
  s.real(q.x()).real(q.y()).real(q.z()).real(q.w());
  // Row-major, as the matrix reads.
  const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> j = g.bias_jacobian;
  Bytes jacobian;
  encode_f64s(std::span<const double>(j.data(), 9), jacobian);
  s.blob(jacobian).real(g.dt);
  end_row(t);
  ++counts_.gyro_links;
}

void MapWriter::markers(KeyframeId keyframe,
                        std::span<const markers::MarkerObservation> observations) {
  Table& t = tables_.at("markers");
  for (std::size_t i = 0; i < observations.size(); ++i) {
    const markers::MarkerObservation& m = observations[i];
    Statement& s = begin_row(t);
    s.integer(static_cast<std::int64_t>(keyframe.value())).integer(static_cast<std::int64_t>(i));
    s.integer(m.id);
    for (const Eigen::Vector2d& c : m.corners)
      s.real(c.x()).real(c.y());
    s.integer(m.image_width).integer(m.image_height);
    end_row(t);
    ++counts_.markers;
  }
}

void MapWriter::observation(KeyframeId keyframe, std::uint32_t keypoint, MapPointId point) {
  Table& t = tables_.at("observations");
  Statement& s = begin_row(t);
  s.integer(static_cast<std::int64_t>(keyframe.value())).integer(keypoint);
  s.integer(static_cast<std::int64_t>(point.value()));
  end_row(t);
  ++counts_.observations;
}

void MapWriter::observations(KeyframeId keyframe, std::span<const MapPointId> points) {
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (points[i].valid()) observation(keyframe, static_cast<std::uint32_t>(i), points[i]);
  }
}

void MapWriter::observations(KeyframeId keyframe, std::span<const std::uint32_t> keypoints,
                             std::span<const MapPointId> points) {
  for (std::size_t i = 0; i < points.size(); ++i)
    observation(keyframe, keypoints[i], points[i]);
}

void MapWriter::edge(KeyframeId keyframe, KeyframeId other, int weight) {
  Table& t = tables_.at("covisibility");
  Statement& s = begin_row(t);
  s.integer(static_cast<std::int64_t>(keyframe.value()));
  s.integer(static_cast<std::int64_t>(other.value())).integer(weight);
  end_row(t);
  ++counts_.covisibility;
}

void MapWriter::covisibility(KeyframeId keyframe, const std::map<KeyframeId, int>& edges) {
  for (const auto& [other, weight] : edges)
    edge(keyframe, other, weight);
}

void MapWriter::covisibility(KeyframeId keyframe,
                             std::span<const std::pair<KeyframeId, int>> edges) {
  for (const auto& [other, weight] : edges)
    edge(keyframe, other, weight);
}

void MapWriter::loop_edge(KeyframeId keyframe, KeyframeId other) {
  Table& t = tables_.at("loop_edges");
  Statement& s = begin_row(t);
  s.integer(static_cast<std::int64_t>(keyframe.value()));
  s.integer(static_cast<std::int64_t>(other.value()));
  end_row(t);
  ++counts_.loop_edges;
}

void MapWriter::loop_edges(KeyframeId keyframe, std::span<const KeyframeId> others) {
  for (KeyframeId other : others)
    loop_edge(keyframe, other);
}

void MapWriter::loop_edges(KeyframeId keyframe, const std::set<KeyframeId>& others) {
  for (KeyframeId other : others)
    loop_edge(keyframe, other);
}

void MapWriter::point(const PointRow& p) {
  Table& t = tables_.at("map_points");
  Statement& s = begin_row(t);
  s.integer(static_cast<std::int64_t>(p.id.value()));
  s.real(p.position.x()).real(p.position.y()).real(p.position.z());
  encode_descriptor(p.descriptor, (descriptor_.clear(), descriptor_));
  s.blob(descriptor_).real(p.normal.x()).real(p.normal.y()).real(p.normal.z());
  s.real(p.min_distance).real(p.max_distance);
  bind_id(s, p.reference);
  bind_id(s, p.first_keyframe);
  s.integer(p.visible).integer(p.found);
  end_row(t);
  ++counts_.points;
}

void MapWriter::erased(KeyframeId keyframe, const map::ErasedKeyframe& e) {
  Table& t = tables_.at("erased_keyframes");
  Statement& s = begin_row(t);
  s.integer(static_cast<std::int64_t>(keyframe.value()));
  s.integer(static_cast<std::int64_t>(e.parent.value()));
  encode_pose(e.cam_from_parent, pose_);
  s.blob(pose_);
  end_row(t);
  ++counts_.erased_keyframes;
}

void MapWriter::finish(KeyframeId first_keyframe, std::uint64_t next_keyframe_id,
                       std::uint64_t next_point_id) {
  Table& features = tables_.at("keyframe_features");
  if (feature_hashes_.size() != keyframe_ids_.size())
    throw Error("save_map: " + std::to_string(feature_hashes_.size()) + " features rows for " +
                    std::to_string(keyframe_ids_.size()) + " keyframes",
                {.file = db_.path().string(), .field = "keyframe_features"});
  for (KeyframeId k : keyframe_ids_) {
    if (!feature_hashes_.count(k))
      throw Error("save_map: no features for keyframe " + std::to_string(k.value()),
                  {.file = db_.path().string(), .field = "keyframe_features"});
  }
  for (const auto& [id, h] : feature_hashes_)
    features.hash.fold(h);
  features.rows = feature_hashes_.size();
  Table& depth = tables_.at("keyframe_depth");
  for (const auto& [id, h] : depth_hashes_) {
    if (!feature_hashes_.count(id))
      throw Error("save_map: depth of a keyframe that is not saved: " + std::to_string(id.value()),
                  {.file = db_.path().string(), .field = "keyframe_depth"});
    depth.hash.fold(h);
  }
  depth.rows = depth_hashes_.size();
  counts_.keyframe_depths = depth.rows;

  MetadataEntries entries = metadata_entries(metadata_);
  entries["coloc_version"] = COLOC_VERSION;
  entries["saved_utc"] = utc_now();
  entries["first_keyframe"] = first_keyframe.valid() ? std::to_string(first_keyframe.value()) : "";
  entries["next_keyframe_id"] = std::to_string(next_keyframe_id);
  entries["next_point_id"] = std::to_string(next_point_id);
  for (const auto& [name, t] : tables_) {
    if (name == "metadata") continue;
    entries["count." + name] = std::to_string(t.rows);
    entries["checksum." + name] = hex64(t.hash.value());
  }
  entries["checksum.metadata"] = hex64(metadata_checksum(entries));
  Table& meta = tables_.at("metadata");
  for (const auto& [key, value] : entries) {
    meta.insert.text(key).text(value);
    meta.insert.run();
  }
  db_.exec("COMMIT");
  tables_.clear();
  delete_features_.reset();
  delete_depth_.reset();
  db_.close();
}

std::string utc_now() {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

}  // namespace coloc::slam::mapdb::detail
