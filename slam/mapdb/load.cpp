// load_map(): every table read in key order, every reference checked, the Map restored and
// what is derived rebuilt.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <string>
#include <thread>
#include <unordered_map>
#include <utility>

#include "slam/core/error.hpp"
#include "slam/core/parallel.hpp"
#include "slam/mapdb/codec.hpp"
#include "slam/mapdb/reader.hpp"
#include "slam/mapdb/schema.hpp"

namespace coloc::slam::mapdb {

namespace fs = std::filesystem;

void LoadOptions::check() const {
  if (cache_mib < 1 || cache_mib > 4096) throw Error("LoadOptions: cache_mib not in 1..4096");
  if (threads < 0) throw Error("LoadOptions: threads negative");
}

namespace detail {
namespace {

std::string row_of(std::uint64_t id) {
  return std::to_string(id);
}

std::string row_of(std::uint64_t a, std::uint64_t b) {
  std::string r = "(";  // appended, not operator+: GCC 12 false -Wrestrict (bug 105329)
  r += std::to_string(a);
  r += ", ";
  r += std::to_string(b);
  r += ')';
  return r;
}

std::optional<Camera> camera_of(TableReader& t, const std::string& row,
                                const frame::FrameGeometry& g) {
  Statement& s = t.row();
  const std::string model = s.column_text(1);
  if (s.column_blob(8).size() % 8 != 0) t.fail("distortion", row, "blob size not a multiple of 8");
  const std::vector<double> d = decode_f64s(s.column_blob(8));
  const auto width = static_cast<int>(s.column_integer(2));
  const auto height = static_cast<int>(s.column_integer(3));
  if (model == "none") return std::nullopt;
  if (model == "PinHole" && d.size() == 5) {
    PinholeCamera c{width, height, g.fx, g.fy, g.cx, g.cy, {}};
    std::copy(d.begin(), d.end(), c.distortion.begin());
    return c;
  }
  if (model == "KannalaBrandt8" && d.size() == 4) {
    KannalaBrandtCamera c{width, height, g.fx, g.fy, g.cx, g.cy, {}};
    std::copy(d.begin(), d.end(), c.distortion.begin());
    return c;
  }
  t.fail("model", row,
         "unknown model '" + model + "' with " + std::to_string(d.size()) + " coefficients");
}

// What the `keyframes` row says besides the Keyframe's own fields.
struct KeyframeColumns {
  map::Keyframe keyframe;
  FrameId frame_id;
  double timestamp = 0.0;
  std::shared_ptr<const frame::FrameGeometry> geometry;
  SE3 cam_from_world;
  bool has_pose = false;
  int image_width = 0, image_height = 0;
  std::size_t keypoint_count = 0;
};

// One load: the tables in dependency order, each row checked against what came before.
class Loader {
 public:
  Loader(const fs::path& path, const bow::Vocabulary* vocabulary, const LoadOptions& options);
  LoadedMap run();

 private:
  void read_metadata();
  void read_cameras();
  void read_keyframes();
  KeyframeColumns keyframe_row(TableReader& t, const std::string& row);
  frame::Frame frame_of(KeyframeColumns& k, TableReader& f, const std::string& row);
  void check_parents();
  void read_markers();
  void read_points();
  void read_observations();
  void read_covisibility();
  void read_loop_edges();
  struct ImuRow {
    map::Keyframe& keyframe;
    KeyframeId recording;
    std::string row;
  };
  ImuRow imu_row(TableReader& t);
  // Every row of an IMU table (none before schema 3): f(table, row) after imu_row's checks.
  template <typename F>
  void read_imu_table(const char* table, F&& f);
  void read_gravity_windows();
  void read_gyro_links();
  void read_keyframe_depth();
  void read_erased();
  void restore();
  void rebuild_bow();
  void advance();

  MapFile file_;
  const bow::Vocabulary* vocabulary_;
  LoadOptions options_;
  LoadedMap out_;
  std::unordered_map<KeyframeId, map::Keyframe> keyframes_;
  std::unordered_map<MapPointId, map::MapPoint> points_;
  std::unordered_map<KeyframeId, map::ErasedKeyframe> erased_;
  map::MapBookkeeping bookkeeping_;
  std::uint64_t done_ = 0, total_ = 0;
};

Loader::Loader(const fs::path& path, const bow::Vocabulary* vocabulary, const LoadOptions& options)
    : file_(path, options.cache_mib), vocabulary_(vocabulary), options_(options) {}

void Loader::advance() {
  if (++done_ % 256 == 0 && options_.progress) options_.progress(done_, total_);
}

LoadedMap Loader::run() {
  read_metadata();
  read_cameras();
  read_keyframes();
  check_parents();
  read_markers();
  read_points();
  read_observations();
  read_covisibility();
  read_loop_edges();
  read_gravity_windows();
  read_gyro_links();
  read_keyframe_depth();
  read_erased();
  restore();
  if (options_.rebuild_bow && vocabulary_) rebuild_bow();
  if (options_.progress) options_.progress(total_, total_);
  return std::move(out_);
}

void Loader::read_metadata() {
  const MetadataEntries& e = file_.entries();
  const fs::path& path = file_.path();
  out_.metadata = parse_metadata(e, path);
  if (vocabulary_) {
    const std::uint64_t ours = vocabulary_checksum(*vocabulary_);
    if (ours != out_.metadata.vocabulary_checksum)
      file_.fail("metadata.vocabulary_checksum", "",
                 "the map was built with another vocabulary (checksum " +
                     hex64(out_.metadata.vocabulary_checksum) + ", this vocabulary's " +
                     hex64(ours) + ")");
  }
  bookkeeping_.next_keyframe_id = entry_u64(e, "next_keyframe_id", path);
  bookkeeping_.next_point_id = entry_u64(e, "next_point_id", path);
  if (!entry(e, "first_keyframe", path).empty())
    bookkeeping_.first_keyframe = KeyframeId(entry_u64(e, "first_keyframe", path));
  const MapCounts c = file_.counts();
  total_ = c.keyframes * (options_.rebuild_bow && vocabulary_ ? 2 : 1) + c.points;
}

void Loader::read_cameras() {
  TableReader t(file_, "cameras");
  while (t.next()) {
    Statement& s = t.row();
    const std::uint64_t id = t.id(0, "id", "?", false);
    const std::string row = row_of(id);
    if (id != out_.geometries.size()) t.fail("id", row, "camera ids must be 0, 1, 2, ...");
    auto g = std::make_shared<frame::FrameGeometry>();
    g->fx = s.column_real(4);
    g->fy = s.column_real(5);
    g->cx = s.column_real(6);
    g->cy = s.column_real(7);
    g->bf = s.column_real(9);
    g->close_depth = s.column_real(10);
    g->min_depth = s.column_real(11);
    g->max_depth = s.column_real(12);
    g->readout = s.column_real(13);
    g->min_x = s.column_real(14);
    g->max_x = s.column_real(15);
    g->min_y = s.column_real(16);
    g->max_y = s.column_real(17);
    g->grid_cols = static_cast<int>(s.column_integer(18));
    g->grid_rows = static_cast<int>(s.column_integer(19));
    if (s.column_blob(20).size() % 4 != 0)
      t.fail("scale_factors", row, "blob size not a multiple of 4");
    // Derived exactly as FrameGeometry::make() derives them.
    g->scale_factors = decode_f32s(s.column_blob(20));
    for (float f : g->scale_factors)
      g->level_sigma2.push_back(f * f);
    if (g->scale_factors.size() > 1) g->log_scale_factor = std::log(g->scale_factors[1]);
    try {
      g->check();
    } catch (const Error& e) {
      t.fail("", row, e.message());
    }
    std::optional<Camera> camera = camera_of(t, row, *g);
    if (id == 0) out_.metadata.camera = camera;
    out_.geometries.push_back(g);
  }
}

// `keyframes` and `keyframe_features` (both in id order) joined into keyframes with frames.
void Loader::read_keyframes() {
  TableReader t(file_, "keyframes");
  TableReader f(file_, "keyframe_features");
  while (t.next()) {
    const std::uint64_t id = t.id(0, "id", "?", false);
    const std::string row = row_of(id);
    if (id >= bookkeeping_.next_keyframe_id)
      t.fail("id", row, "not below the metadata's next_keyframe_id");
    if (!f.next()) f.fail("", row, "no features row for this keyframe");
    const std::uint64_t fid = f.id(0, "keyframe_id", "?", false);
    if (fid != id)
      f.fail("keyframe_id", row_of(std::min(id, fid)),
             fid < id ? "features of a keyframe that does not exist" : "no features row");
    KeyframeColumns k = keyframe_row(t, row);
    k.keyframe.frame = frame_of(k, f, row);
    keyframes_.emplace(k.keyframe.id, std::move(k.keyframe));
    advance();
  }
  if (f.next())
    f.fail("", row_of(f.id(0, "keyframe_id", "?", false)),
           "features of a keyframe that does not exist");
  if (!keyframes_.empty() && !keyframes_.count(bookkeeping_.first_keyframe))
    file_.fail("metadata.first_keyframe", "", "not a keyframe of the map");
}

KeyframeColumns Loader::keyframe_row(TableReader& t, const std::string& row) {
  Statement& s = t.row();
  KeyframeColumns k;
  k.keyframe.id = KeyframeId(t.id(0, "id", row, false));
  k.frame_id = FrameId(t.id(1, "frame_id", row, true));
  k.timestamp = s.column_real(2);
  const std::uint64_t camera = t.id(3, "camera_id", row, false);
  if (camera >= out_.geometries.size()) t.fail("camera_id", row, "no such camera");
  k.geometry = out_.geometries[camera];
  if (s.column_blob(11).size() != kPoseBytes) t.fail("cam_from_world", row, "not 56 bytes");
  k.cam_from_world = decode_pose(s.column_blob(11));
  k.has_pose = s.column_integer(12) != 0;
  k.keyframe.parent = KeyframeId(t.id(13, "parent", row, true));
  k.image_width = static_cast<int>(s.column_integer(14));
  k.image_height = static_cast<int>(s.column_integer(15));
  const std::int64_t n = s.column_integer(16);
  if (n < 0 || n > (1 << 24)) t.fail("keypoint_count", row, "out of range");
  k.keypoint_count = static_cast<std::size_t>(n);
  k.keyframe.marker_size = s.column_real(17);
  return k;
}

frame::Frame Loader::frame_of(KeyframeColumns& k, TableReader& f, const std::string& row) {
  Statement& s = f.row();
  const auto keypoints = s.column_blob(1);
  const auto descriptors = s.column_blob(2);
  const std::size_t n = k.keypoint_count;
  if (keypoints.size() != n * kKeypointRecordBytes)
    f.fail("keypoints", row,
           "blob has " + std::to_string(keypoints.size()) + " bytes, expected " +
               std::to_string(n) + " keypoints x " + std::to_string(kKeypointRecordBytes));
  if (descriptors.size() != n * kDescriptorBytes)
    f.fail("descriptors", row,
           "blob has " + std::to_string(descriptors.size()) + " bytes, expected " +
               std::to_string(n) + " x " + std::to_string(kDescriptorBytes));
  ContentHash own;
  own.integer(s.column_integer(0));
  own.blob(keypoints);
  own.blob(descriptors);
  if (static_cast<std::uint64_t>(s.column_integer(3)) != own.value())
    f.fail("checksum", row, "the keypoints or descriptors are damaged (row checksum mismatch)");
  KeypointData d = decode_keypoints(keypoints, n);
  features::OrbFeatures feats;
  feats.keypoints = std::move(d.keypoints);
  feats.descriptors = decode_descriptors(descriptors, n);
  feats.image_width = k.image_width;
  feats.image_height = k.image_height;
  frame::Frame frame(k.frame_id, k.timestamp, std::move(feats), std::move(d.depth),
                     std::move(d.u_right), k.geometry);
  frame.outlier = std::move(d.outlier);
  if (!options_.keyframe_search) frame.drop_search_data();
  frame.cam_from_world = k.cam_from_world;
  frame.has_pose = k.has_pose;
  return frame;
}

void Loader::read_markers() {
  TableReader t(file_, "markers");
  while (t.next()) {
    Statement& s = t.row();
    const std::uint64_t kf = t.id(0, "keyframe_id", "?", false);
    const std::uint64_t seq = t.id(1, "seq", "?", false);
    const std::string row = row_of(kf, seq);
    auto it = keyframes_.find(KeyframeId(kf));
    if (it == keyframes_.end()) t.fail("keyframe_id", row, "no such keyframe");
    if (seq != it->second.markers.size()) t.fail("seq", row, "markers out of sequence");
    markers::MarkerObservation m;
    m.id = static_cast<int>(s.column_integer(2));
    for (int c = 0; c < 4; ++c)
      m.corners[static_cast<std::size_t>(c)] = {s.column_real(3 + 2 * c), s.column_real(4 + 2 * c)};
    m.image_width = static_cast<int>(s.column_integer(11));
    m.image_height = static_cast<int>(s.column_integer(12));
    it->second.markers.push_back(m);
  }
}

void Loader::read_points() {
  TableReader t(file_, "map_points");
  while (t.next()) {
    Statement& s = t.row();
    map::MapPoint p;
    p.id = MapPointId(t.id(0, "id", "?", false));
    const std::string row = row_of(p.id.value());
    if (p.id.value() >= bookkeeping_.next_point_id)
      t.fail("id", row, "not below the metadata's next_point_id");
    p.position = {s.column_real(1), s.column_real(2), s.column_real(3)};
    if (s.column_blob(4).size() != kDescriptorBytes) t.fail("descriptor", row, "not 32 bytes");
    p.descriptor = decode_descriptor(s.column_blob(4));
    p.normal = {s.column_real(5), s.column_real(6), s.column_real(7)};
    p.min_distance = s.column_real(8);
    p.max_distance = s.column_real(9);
    // Not checked against the keyframes: the Map keeps a point's first keyframe after that
    // keyframe is erased, and tolerates a missing reference.
    p.reference = KeyframeId(t.id(10, "reference_keyframe", row, true));
    p.first_keyframe = KeyframeId(t.id(11, "first_keyframe", row, true));
    p.visible = static_cast<int>(s.column_integer(12));
    p.found = static_cast<int>(s.column_integer(13));
    points_.emplace(p.id, std::move(p));
    advance();
  }
}

void Loader::read_observations() {
  // Checked and collected first, then handed to each point at once with its exact capacity:
  // the rows come keyframe by keyframe, so each point's list would grow by doubling and leave
  // its outgrown arrays as holes in the heap (a site map: 147,000 points, 4.4 observations
  // each). The collection is one large array, returned to the system when freed.
  struct Row {
    map::MapPoint* point;
    KeyframeId keyframe;
    std::uint32_t index;
  };
  std::vector<Row> rows;
  TableReader t(file_, "observations");
  while (t.next()) {
    const std::uint64_t kf_id = t.id(0, "keyframe_id", "?", false);
    const std::uint64_t index = t.id(1, "keypoint", "?", false);
    const std::string row = row_of(kf_id, index);
    const MapPointId pid(t.id(2, "point_id", row, false));
    auto kf = keyframes_.find(KeyframeId(kf_id));
    if (kf == keyframes_.end()) t.fail("keyframe_id", row, "no such keyframe");
    if (index >= kf->second.frame.size())
      t.fail("keypoint", row,
             "keypoint index out of range (" + std::to_string(kf->second.frame.size()) +
                 " keypoints)");
    auto p = points_.find(pid);
    if (p == points_.end()) t.fail("point_id", row, "no such map point");
    // The primary key (keyframe_id, keypoint) makes a keypoint hold one point; a point seen
    // twice by one keyframe is found below, after the rows are grouped by point.
    rows.push_back({&p->second, kf->first, static_cast<std::uint32_t>(index)});
    kf->second.frame.points[index] = pid;
  }
  // By point, then keyframe (stable: the rows' order within a keyframe stays).
  std::stable_sort(rows.begin(), rows.end(), [](const Row& a, const Row& b) {
    return a.point != b.point ? std::less<>()(a.point, b.point) : a.keyframe < b.keyframe;
  });
  for (std::size_t i = 0; i < rows.size();) {
    std::size_t j = i;
    while (j < rows.size() && rows[j].point == rows[i].point)
      ++j;
    map::MapPoint& p = *rows[i].point;
    p.observations.reserve(j - i);
    for (; i < j; ++i) {
      if (!p.observations.emplace(rows[i].keyframe, rows[i].index).second)
        t.fail("point_id", row_of(rows[i].keyframe.value(), rows[i].index),
               "the point is observed twice by this keyframe");
    }
  }
}

void Loader::read_covisibility() {
  TableReader t(file_, "covisibility");
  while (t.next()) {
    const KeyframeId a(t.id(0, "keyframe_id", "?", false));
    const KeyframeId b(t.id(1, "other_id", "?", false));
    const std::string row = row_of(a.value(), b.value());
    auto kf = keyframes_.find(a);
    if (kf == keyframes_.end()) t.fail("keyframe_id", row, "no such keyframe");
    if (a == b || !keyframes_.count(b)) t.fail("other_id", row, "no such other keyframe");
    kf->second.covisibility[b] = static_cast<int>(t.row().column_integer(2));
  }
}

// Schema version 2 on; a version-1 file has no loop edges. Each edge is stored once per
// direction, both to keyframes of the map.
void Loader::read_loop_edges() {
  if (!has_table(file_.schema_version(), "loop_edges")) return;
  TableReader t(file_, "loop_edges");
  std::vector<std::pair<KeyframeId, KeyframeId>> rows;
  while (t.next()) {
    const KeyframeId a(t.id(0, "keyframe_id", "?", false));
    const KeyframeId b(t.id(1, "other_id", "?", false));
    const std::string row = row_of(a.value(), b.value());
    auto kf = keyframes_.find(a);
    if (kf == keyframes_.end()) t.fail("keyframe_id", row, "no such keyframe");
    if (a == b || !keyframes_.count(b)) t.fail("other_id", row, "no such other keyframe");
    kf->second.loop_edges.insert(b);
    rows.emplace_back(a, b);
  }
  for (const auto& [a, b] : rows) {
    if (!keyframes_.at(b).loop_edges.count(a))
      file_.fail("loop_edges.other_id", row_of(a.value(), b.value()),
                 "no reverse row " + row_of(b.value(), a.value()) +
                     " (a loop edge is stored in both directions)");
  }
}

// Columns 0-1 of an IMU table: the keyframe the row belongs to, which must exist, and its
// recording (the id of the recording's first keyframe), which cannot start after it.
Loader::ImuRow Loader::imu_row(TableReader& t) {
  const KeyframeId id(t.id(0, "keyframe_id", "?", false));
  std::string row = row_of(id.value());
  auto kf = keyframes_.find(id);
  if (kf == keyframes_.end()) t.fail("keyframe_id", row, "no such keyframe");
  const KeyframeId recording(t.id(1, "recording", row, false));
  if (recording > id) t.fail("recording", row, "a recording that starts after its keyframe");
  return {kf->second, recording, std::move(row)};
}

// Schema version 3 on: the IMU's measurements a recording stored with its keyframes.
template <typename F>
void Loader::read_imu_table(const char* table, F&& f) {
  if (!has_table(file_.schema_version(), table)) return;
  TableReader t(file_, table);
  while (t.next())
    f(t, imu_row(t));
}

void Loader::read_gravity_windows() {
  read_imu_table("gravity_windows", [](TableReader& t, const ImuRow& r) {
    Statement& s = t.row();
    map::GravityWindow g;
    g.recording = r.recording;
    g.specific_force_cam = {s.column_real(2), s.column_real(3), s.column_real(4)};
    g.accel_world = {s.column_real(5), s.column_real(6), s.column_real(7)};
    if (!g.specific_force_cam.allFinite() || !g.accel_world.allFinite())
      t.fail("fx", r.row, "not a finite measurement");
    r.keyframe.gravity = g;
  });
}

void Loader::read_gyro_links() {
  read_imu_table("gyro_links", [this](TableReader& t, const ImuRow& r) {
    Statement& s = t.row();
    const std::string& row = r.row;
    map::GyroLink g;
    g.recording = r.recording;
    g.next = KeyframeId(t.id(2, "next_id", row, false));
    if (g.next == r.keyframe.id || !keyframes_.count(g.next))
      t.fail("next_id", row, "no such other keyframe");
    const Eigen::Quaterniond q(s.column_real(6), s.column_real(3), s.column_real(4),
                               s.column_real(5));
    if (!(std::abs(q.norm() - 1.0) < 1e-9)) t.fail("qw", row, "not a unit quaternion");
    g.cam_from_next = SO3::from_unit_quaternion(q);
    if (s.column_blob(7).size() != kBiasJacobianBytes)
      t.fail("bias_jacobian", row, "not 72 bytes (3 x 3 doubles)");
    const std::vector<double> j = decode_f64s(s.column_blob(7));
    g.bias_jacobian = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(j.data());
    g.dt = s.column_real(8);
    if (!(g.dt > 0.0) || !g.bias_jacobian.allFinite())
      t.fail("dt", row, "not a positive interval with a finite bias Jacobian");
    r.keyframe.gyro = g;
  });
}

// Schema version 4 on: each keyframe's small depth image. Sizes are checked before the blob is
// touched, so a damaged row is an error naming it, never a huge allocation or a read past it.
void Loader::read_keyframe_depth() {
  if (!options_.keyframe_depth || !has_table(file_.schema_version(), "keyframe_depth")) return;
  TableReader t(file_, "keyframe_depth");
  while (t.next()) {
    Statement& s = t.row();
    const KeyframeId id(t.id(0, "keyframe_id", "?", false));
    const std::string row = row_of(id.value());
    auto kf = keyframes_.find(id);
    if (kf == keyframes_.end()) t.fail("keyframe_id", row, "no such keyframe");
    const std::int64_t width = s.column_integer(1), height = s.column_integer(2);
    const std::int64_t factor = s.column_integer(3);
    const auto side_ok = [](std::int64_t v) { return v >= 1 && v <= map::KeyframeDepth::kMaxSide; };
    if (!side_ok(width))
      t.fail("width", row,
             std::to_string(width) + " not in 1.." + std::to_string(map::KeyframeDepth::kMaxSide));
    if (!side_ok(height))
      t.fail("height", row,
             std::to_string(height) + " not in 1.." + std::to_string(map::KeyframeDepth::kMaxSide));
    if (factor < 1 || factor > map::KeyframeDepth::kMaxFactor)
      t.fail(
          "factor", row,
          std::to_string(factor) + " not in 1.." + std::to_string(map::KeyframeDepth::kMaxFactor));
    const features::OrbFeatures& image = kf->second.frame.features;
    if (image.image_width > 0 && image.image_height > 0 &&
        (width * factor > image.image_width || height * factor > image.image_height))
      t.fail("width", row,
             std::to_string(width) + " x " + std::to_string(height) + " pixels of factor " +
                 std::to_string(factor) + " exceed the keyframe's " +
                 std::to_string(image.image_width) + " x " + std::to_string(image.image_height) +
                 " image");
    const auto blob = s.column_blob(4);
    const auto expected = static_cast<std::size_t>(width * height) * kDepthPixelBytes;
    if (blob.size() != expected)
      t.fail("depth", row,
             "blob has " + std::to_string(blob.size()) + " bytes, expected " +
                 std::to_string(width) + " x " + std::to_string(height) + " x " +
                 std::to_string(kDepthPixelBytes));
    ContentHash own;
    own.integer(s.column_integer(0));
    own.integer(width);
    own.integer(height);
    own.integer(factor);
    own.blob(blob);
    if (static_cast<std::uint64_t>(s.column_integer(5)) != own.value())
      t.fail("checksum", row, "the depth image is damaged (row checksum mismatch)");
    map::KeyframeDepth d;
    d.width = static_cast<int>(width);
    d.height = static_cast<int>(height);
    d.factor = static_cast<int>(factor);
    d.millimetres = decode_u16s(blob);
    kf->second.depth = std::move(d);
  }
}

void Loader::check_parents() {
  for (const auto& [id, kf] : keyframes_) {
    if (!kf.parent.valid()) continue;
    if (id == bookkeeping_.first_keyframe)
      file_.fail("keyframes.parent", row_of(id.value()), "the first keyframe has a parent");
    if (!keyframes_.count(kf.parent))
      file_.fail("keyframes.parent", row_of(id.value()),
                 "parent " + row_of(kf.parent.value()) + " is not a keyframe of the map");
  }
}

void Loader::read_erased() {
  TableReader t(file_, "erased_keyframes");
  while (t.next()) {
    const KeyframeId id(t.id(0, "id", "?", false));
    const std::string row = row_of(id.value());
    if (keyframes_.count(id)) t.fail("id", row, "an erased keyframe that is also in the map");
    map::ErasedKeyframe e;
    e.parent = KeyframeId(t.id(1, "parent", row, false));
    if (t.row().column_blob(2).size() != kPoseBytes) t.fail("cam_from_parent", row, "not 56 bytes");
    e.cam_from_parent = decode_pose(t.row().column_blob(2));
    erased_.emplace(id, e);
  }
  for (const auto& [id, e] : erased_) {
    if (!keyframes_.count(e.parent) && !erased_.count(e.parent))
      file_.fail("erased_keyframes.parent", row_of(id.value()),
                 "parent " + row_of(e.parent.value()) + " is neither a keyframe nor erased");
  }
}

void Loader::restore() {
  bookkeeping_.erased = std::move(erased_);
  try {
    out_.map = map::Map::restore(std::move(keyframes_), std::move(points_), bookkeeping_);
  } catch (const Error& e) {
    // The reads above checked every reference; what remains is the tree's shape.
    file_.fail("keyframes.parent", "", e.message());
  }
}

// BoW vectors on every core (the vocabulary is immutable, keyframes are disjoint), then the
// database in id order.
void Loader::rebuild_bow() {
  std::vector<map::Keyframe*> keyframes;
  for (const auto& [id, kf] : out_.map.keyframes())
    keyframes.push_back(out_.map.keyframe(id));
  std::sort(keyframes.begin(), keyframes.end(),
            [](const map::Keyframe* a, const map::Keyframe* b) { return a->id < b->id; });
  const std::uint64_t base = done_;
  const std::thread::id caller = std::this_thread::get_id();
  parallel_for(keyframes.size(), options_.threads, [&](std::size_t i) {
    frame::Frame& f = keyframes[i]->frame;
    vocabulary_->transform(f.features.descriptors, f.bow, f.feature_vector);
    // Only the calling thread reports progress (the callback need not be thread-safe); it may
    // throw to cancel, which stops the other threads at their next keyframe.
    if (std::this_thread::get_id() == caller && i % 64 == 0 && options_.progress)
      options_.progress(base + i, total_);
  });
  std::vector<const bow::BowVector*> bows;
  bows.reserve(keyframes.size());
  for (const map::Keyframe* kf : keyframes)
    bows.push_back(&kf->frame.bow);
  out_.database.reserve(bows);
  for (map::Keyframe* kf : keyframes) {
    out_.database.add(kf->id.value(), kf->frame.bow);
    if (!options_.keyframe_bow) kf->frame.bow = {};  // the database keeps the weights
  }
  done_ = base + keyframes.size();
}

}  // namespace
}  // namespace detail

LoadedMap load_map(const fs::path& path, const bow::Vocabulary& vocabulary,
                   const LoadOptions& options) {
  options.check();
  const auto start = std::chrono::steady_clock::now();
  LoadedMap m = detail::Loader(path, &vocabulary, options).run();
  spdlog::debug("loaded {} keyframes, {} points from {} in {:.2f} s", m.map.keyframe_count(),
                m.map.point_count(), path.string(),
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  return m;
}

VerifyReport verify_map(const fs::path& path, const bow::Vocabulary* vocabulary,
                        const ProgressFn& progress) {
  VerifyReport report;
  try {
    report.info = read_map_info(path);
  } catch (const Error& e) {
    report.problems.push_back(e.what());
    return report;
  }
  report.problems = detail::integrity_problems(path);
  LoadOptions options;
  options.rebuild_bow = false;
  options.progress = progress;
  try {
    detail::Loader(path, vocabulary, options).run();
  } catch (const Error& e) {
    report.problems.push_back(e.what());
  }
  return report;
}

Camera camera_of(const LoadedMap& map, const std::filesystem::path& file) {
  if (map.metadata.camera) return *map.metadata.camera;
  if (map.geometries.empty())
    throw Error("the map has no camera", {.file = file.string(), .field = "cameras"});
  const frame::FrameGeometry& g = *map.geometries.front();
  PinholeCamera c;
  c.fx = g.fx;
  c.fy = g.fy;
  c.cx = g.cx;
  c.cy = g.cy;
  c.width = static_cast<int>(g.max_x);
  c.height = static_cast<int>(g.max_y);
  return c;
}

}  // namespace coloc::slam::mapdb
