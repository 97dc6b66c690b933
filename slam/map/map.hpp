#pragma once
// The SLAM map: keyframes and map points as plain values owned by the Map and keyed by the ids
// it issues (COLMAP's id-keyed scene). Relations are ids, never pointers: a point lists the
// keyframes (and keypoint indices) observing it, a keyframe lists the point of each keypoint.
// The Map keeps those two sides consistent, and maintains the covisibility graph (weights =
// shared points), the spanning tree (parent = strongest covisible keyframe when it joined) and
// each point's best descriptor, mean viewing direction and scale-invariance distances.
//
// Thread-safety: none inside. The System owns one Map behind one mutex (SharedMap in
// slam/system); tracking and local mapping hold that lock whenever they read or write the Map.
// Units: metres; poses cam_from_world.
#include <Eigen/Core>
#include <map>
#include <optional>
#include <set>
#include <unordered_map>
#include <vector>

#include "markers/observation.hpp"
#include "slam/core/ids.hpp"
#include "slam/core/se3.hpp"
#include "slam/frame/frame.hpp"
#include "slam/map/inertial.hpp"
#include "slam/map/keyframe_depth.hpp"
#include "slam/map/observations.hpp"

namespace coloc::slam::map {

struct Keyframe {
  KeyframeId id;
  frame::Frame frame;  // features, depth, matched points (frame.points) and pose
  // Covisibility: keyframe -> number of shared points (only weights >= 15, or the best one).
  std::map<KeyframeId, int> covisibility;
  std::vector<KeyframeId> covisible_ordered;  // by decreasing weight
  KeyframeId parent;                          // spanning tree (invalid for the first keyframe)
  std::set<KeyframeId> children;
  // Loop closures this keyframe takes part in (both sides list each other): essential-graph
  // edges that survive covisibility changes. Erasing a keyframe hands its edges to its parent.
  std::set<KeyframeId> loop_edges;
  std::vector<markers::MarkerObservation> markers;  // fiducials seen in this keyframe
  double marker_size = 0.0;  // edge length of those markers (metres), from the settings
  // The IMU's measurements, once its recording stored them (mapping::record_inertial). Erasing
  // a keyframe chains the link that led to it with its own.
  std::optional<GravityWindow> gravity;
  std::optional<GyroLink> gyro;  // to gyro->next
  // The frame's depth image, downsampled (keyframe_depth.hpp): tracking keeps it so that a saved
  // map registers without the recording it was built from. None in maps from older files and
  // in maps built without depth images.
  std::optional<KeyframeDepth> depth;

  const SE3& cam_from_world() const { return frame.cam_from_world; }
  Eigen::Vector3d camera_centre() const { return frame.camera_centre(); }
  const std::vector<MapPointId>& points() const { return frame.points; }
};

struct MapPoint {
  MapPointId id;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // world, metres
  features::Descriptor descriptor{};                   // the most central observation
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();   // mean unit viewing direction
  double min_distance = 0.0, max_distance = 0.0;       // scale-invariance range (metres)
  KeyframeId reference;                                // keyframe that created it
  KeyframeId first_keyframe;
  Observations observations;  // keyframe -> keypoint index, ascending keyframe id
  int visible = 1;            // frames whose frustum contained it
  int found = 1;              // frames that matched it
  double found_ratio() const { return static_cast<double>(found) / std::max(visible, 1); }
  // Predicted pyramid level at a distance (metres).
  int predict_level(double distance, const frame::FrameGeometry& g) const;
};

// What remains of an erased keyframe: enough to chain a frame's relative pose to the map.
struct ErasedKeyframe {
  KeyframeId parent;
  SE3 cam_from_parent;
};

// What a saved map needs besides its keyframes and points to come back exactly (slam/mapdb):
// the ids issued so far, the root of the spanning tree and the chain of erased keyframes.
struct MapBookkeeping {
  KeyframeId first_keyframe;
  std::uint64_t next_keyframe_id = 0;  // the id value next_keyframe_id() issues next
  std::uint64_t next_point_id = 0;     // the id value next_point_id() issues next
  std::unordered_map<KeyframeId, ErasedKeyframe> erased;
};

class Map {
 public:
  KeyframeId next_keyframe_id() { return keyframe_ids_.next(); }
  // The id next_keyframe_id() will issue: every keyframe made from now on has it or a later one.
  KeyframeId upcoming_keyframe_id() const { return KeyframeId(keyframe_ids_.peek()); }
  MapPointId next_point_id() { return point_ids_.next(); }

  // Inserts a keyframe (id from next_keyframe_id()); its frame.points must all exist (or be
  // invalid). Adds its observations to those points.
  Keyframe& add_keyframe(Keyframe keyframe);
  // A new point observed by `keyframe` at keypoint `index`.
  MapPoint& add_point(const Eigen::Vector3d& position, KeyframeId keyframe, std::uint32_t index);
  void add_observation(MapPointId point, KeyframeId keyframe, std::uint32_t index);
  void erase_observation(MapPointId point, KeyframeId keyframe);
  void erase_point(MapPointId point);
  // Keeps the point with more observations; the other's observations move to it.
  void replace_point(MapPointId from, MapPointId to);
  // Erases a keyframe, reconnecting its children in the spanning tree, handing its loop edges
  // to its parent and chaining the gyro link that led to it with its own (map::chain).
  void erase_keyframe(KeyframeId keyframe);

  // Recomputes the keyframe's covisibility edges (both directions) and, the first time, its
  // spanning-tree parent.
  void update_connections(KeyframeId keyframe);
  // Best descriptor (least median distance to the others), normal and distance range.
  void update_point(MapPointId point);
  // ORB-SLAM2's observation count: an observation with depth (stereo-like) counts twice.
  int weighted_observations(MapPointId point) const;
  // Up to n best covisible keyframes (all when n == 0).
  std::vector<KeyframeId> covisible(KeyframeId keyframe, std::size_t n = 0) const;

  Keyframe* keyframe(KeyframeId id);
  const Keyframe* keyframe(KeyframeId id) const;
  MapPoint* point(MapPointId id);
  const MapPoint* point(MapPointId id) const;
  const std::unordered_map<KeyframeId, Keyframe>& keyframes() const { return keyframes_; }
  // Calls f(Keyframe&) for every keyframe (to change keyframes in place, never the set).
  template <typename F>
  void for_each_keyframe(F&& f) {
    for (auto& [id, kf] : keyframes_)
      f(kf);
  }
  const std::unordered_map<MapPointId, MapPoint>& points() const { return points_; }
  // Calls f(MapPoint&) for every point (to move points, never to add or erase them).
  template <typename F>
  void for_each_point(F&& f) {
    for (auto& [id, p] : points_)
      f(p);
  }
  // cam_from_world of a keyframe, following erased keyframes through their parents.
  std::optional<SE3> keyframe_pose(KeyframeId id) const;
  std::size_t keyframe_count() const { return keyframes_.size(); }
  std::size_t point_count() const { return points_.size(); }
  KeyframeId first_keyframe() const { return first_keyframe_; }

  // --- Saving and restoring (slam/mapdb) ---------------------------------------------------
  // Ids, root and erased chain as a save must carry them (the erased chain is copied: one
  // small entry per culled keyframe).
  MapBookkeeping bookkeeping() const;
  const std::unordered_map<KeyframeId, ErasedKeyframe>& erased_keyframes() const { return erased_; }
  // Rebuilds a map exactly as it was saved. The editing API cannot: it issues new ids, drops
  // duplicate observations and recomputes point statistics and connections. Keyframes come
  // with frame.points, covisibility and parent; points with their observations; both sides of
  // every observation must agree. Derived here, as the editing API maintains them: children
  // (from the parents) and covisible_ordered (from covisibility). Throws coloc::Error naming
  // the first relation that does not hold (ids at or above the issuers' next values, a side of
  // an observation missing, an edge, gyro link or parent to a missing keyframe, a spanning-tree
  // cycle, an erased keyframe that is also present or chains to nothing).
  static Map restore(std::unordered_map<KeyframeId, Keyframe> keyframes,
                     std::unordered_map<MapPointId, MapPoint> points, MapBookkeeping bookkeeping);

 private:
  // restore()'s checks, split by relation.
  void check_restored_observations() const;
  void check_restored_tree() const;

  std::unordered_map<KeyframeId, Keyframe> keyframes_;
  std::unordered_map<MapPointId, MapPoint> points_;
  std::unordered_map<KeyframeId, ErasedKeyframe> erased_;
  IdIssuer<KeyframeId> keyframe_ids_;
  IdIssuer<MapPointId> point_ids_;
  KeyframeId first_keyframe_;
};

}  // namespace coloc::slam::map
