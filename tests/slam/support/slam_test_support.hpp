#pragma once
// Shared by the SLAM system tests: the shipped vocabulary (loaded once per test binary) and the
// source tree it is read from, a small test camera, and the map consistency check.
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <random>
#include <string>
#include <vector>

#include "slam/bow/vocabulary.hpp"
#include "slam/frame/frame.hpp"
#include "slam/map/map.hpp"

namespace coloc::slam::test_support {

inline std::filesystem::path source_dir() {
  if (const char* env = std::getenv("COLOC_SOURCE_DIR")) return env;
  return COLOC_TEST_SOURCE_DIR;
}

// Loaded once per binary (an inline function's static is shared by every test file): the
// vocabulary takes a moment to read.
inline const bow::Vocabulary& vocabulary() {
  static const bow::Vocabulary kVocabulary =
      bow::Vocabulary::load(source_dir() / "Vocabulary/coloc_orb_k10_L5.cvoc");
  return kVocabulary;
}

// 640x480 pinhole, f = 500, bf = 40, close depth 3 m, three pyramid levels.
inline std::shared_ptr<const frame::FrameGeometry> test_geometry() {
  PinholeCamera cam;
  cam.width = 640;
  cam.height = 480;
  cam.fx = cam.fy = 500.0;
  cam.cx = 320.0;
  cam.cy = 240.0;
  return std::make_shared<frame::FrameGeometry>(
      frame::FrameGeometry::make(cam, 40.0, 3.0, {1.0f, 1.2f, 1.44f}));
}

// A keyframe with n keypoints on a row (9 px apart from x = 20, y = 240), all at depth 2 m,
// with distinct descriptors, its camera centre at `centre` looking along +z.
inline map::Keyframe row_keyframe(map::Map& m, std::size_t n, const Eigen::Vector3d& centre) {
  features::OrbFeatures f;
  for (std::size_t i = 0; i < n; ++i) {
    features::Keypoint kp;
    kp.x = kp.ux = 20.0f + 9.0f * static_cast<float>(i);
    kp.y = kp.uy = 240.0f;
    f.keypoints.push_back(kp);
    features::Descriptor d{};
    d[0] = (i + 1) * 0x9e3779b97f4a7c15ULL;
    f.descriptors.push_back(d);
  }
  map::Keyframe kf;
  kf.id = m.next_keyframe_id();
  kf.frame = frame::Frame(FrameId(kf.id.value()), 0.0, f,
                          cv::Mat(480, 640, CV_32FC1, cv::Scalar(2.0f)), test_geometry());
  kf.frame.cam_from_world = SE3(SO3(), -centre);
  return kf;
}

// Random 256-bit descriptors (pairwise Hamming distances near 128), reproducible by seed.
inline std::vector<features::Descriptor> random_descriptors(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<features::Descriptor> out(n);
  for (auto& d : out)
    for (auto& word : d)
      word = rng();
  return out;
}

// A keyframe whose keypoint i is world point i projected exactly (level 0) through
// `cam_from_world` of the test camera, with descriptor i. With `depth`, each keypoint reads its
// true depth; without, every keypoint is monocular. Points behind the camera or outside the
// image are left out (keypoint indices then skip them: the returned map says which is which).
struct ProjectedKeyframe {
  map::Keyframe keyframe;
  std::vector<int> keypoint_of_point;  // -1 when not visible
};
inline ProjectedKeyframe projected_keyframe(map::Map& m, const std::vector<Eigen::Vector3d>& world,
                                            const std::vector<features::Descriptor>& descriptors,
                                            const SE3& cam_from_world, bool depth) {
  const auto geometry = test_geometry();
  features::OrbFeatures f;
  cv::Mat depth_image(480, 640, CV_32FC1, cv::Scalar(0.0f));
  ProjectedKeyframe out;
  out.keypoint_of_point.assign(world.size(), -1);
  for (std::size_t i = 0; i < world.size(); ++i) {
    const Eigen::Vector3d pc = cam_from_world * world[i];
    if (pc.z() <= 0.1) continue;
    const Eigen::Vector2d uv = geometry->project(pc);
    if (!geometry->in_bounds(uv) || uv.x() < 1 || uv.y() < 1) continue;
    // The depth sits at the rounded pixel, which must be inside the image too (x = 639.6 is
    // in bounds, its pixel 640 is not).
    const int col = static_cast<int>(std::lround(uv.x()));
    const int row = static_cast<int>(std::lround(uv.y()));
    if (col >= depth_image.cols || row >= depth_image.rows) continue;
    features::Keypoint kp;
    kp.x = kp.ux = static_cast<float>(uv.x());
    kp.y = kp.uy = static_cast<float>(uv.y());
    out.keypoint_of_point[i] = static_cast<int>(f.keypoints.size());
    f.keypoints.push_back(kp);
    f.descriptors.push_back(descriptors[i]);
    depth_image.at<float>(row, col) = static_cast<float>(pc.z());
  }
  out.keyframe.id = m.next_keyframe_id();
  out.keyframe.frame = frame::Frame(FrameId(out.keyframe.id.value()), 0.0, std::move(f),
                                    depth ? depth_image : cv::Mat(), geometry);
  out.keyframe.frame.cam_from_world = cam_from_world;
  out.keyframe.frame.has_pose = true;
  return out;
}

// Every relation of the map checked from both sides; returns the first problem found.
inline std::string map_problem(const map::Map& m) {
  const auto id = [](auto k) { return std::to_string(k.value()); };
  for (const auto& [pid, p] : m.points()) {
    for (const auto& [k, idx] : p.observations) {
      const map::Keyframe* kf = m.keyframe(k);
      if (!kf) return "point " + id(pid) + " observed by missing keyframe " + id(k);
      if (idx >= kf->frame.points.size() || kf->frame.points[idx] != pid)
        return "point " + id(pid) + " not at its keypoint in keyframe " + id(k);
    }
    if (!m.keyframe(p.reference)) return "point " + id(pid) + " has a missing reference";
  }
  for (const auto& [k, kf] : m.keyframes()) {
    for (std::size_t i = 0; i < kf.frame.points.size(); ++i) {
      const MapPointId pid = kf.frame.points[i];
      if (!pid.valid()) continue;
      const map::MapPoint* p = m.point(pid);
      if (!p) return "keyframe " + id(k) + " holds missing point " + id(pid);
      auto o = p->observations.find(k);
      if (o == p->observations.end() || o->second != i)
        return "keyframe " + id(k) + " point " + id(pid) + " lacks the observation";
    }
    for (const auto& [other, w] : kf.covisibility) {
      if (!m.keyframe(other)) return "keyframe " + id(k) + " covisible with missing " + id(other);
    }
    for (KeyframeId other : kf.covisible_ordered) {
      if (!m.keyframe(other)) return "keyframe " + id(k) + " ordered with missing " + id(other);
    }
    for (KeyframeId l : kf.loop_edges) {
      const map::Keyframe* other = m.keyframe(l);
      if (!other) return "keyframe " + id(k) + " has a loop edge to missing " + id(l);
      if (!other->loop_edges.count(k)) return "loop edge " + id(k) + "-" + id(l) + " one-sided";
    }
    for (KeyframeId c : kf.children) {
      const map::Keyframe* child = m.keyframe(c);
      if (!child) return "keyframe " + id(k) + " has missing child " + id(c);
      if (child->parent != k) return "child " + id(c) + " of " + id(k) + " has another parent";
    }
    if (k == m.first_keyframe()) {
      if (kf.parent.valid()) return "the first keyframe has a parent";
      continue;
    }
    const map::Keyframe* parent = m.keyframe(kf.parent);
    if (!parent) return "keyframe " + id(k) + " has missing parent " + id(kf.parent);
    if (!parent->children.count(k)) return "parent of " + id(k) + " does not list it";
    // Walking up must reach the root: no cycle.
    KeyframeId up = k;
    for (std::size_t hops = 0; up != m.first_keyframe(); ++hops) {
      if (hops > m.keyframe_count()) return "spanning tree cycle through " + id(k);
      up = m.keyframe(up)->parent;
    }
  }
  return {};
}

}  // namespace coloc::slam::test_support
