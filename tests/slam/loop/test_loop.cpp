// Loop closing on hand-built maps whose keyframes observe exact projections of known points:
// a ring walk whose map drifted (the loop must bring every keyframe back near the truth, which
// neither a closer that finds nothing nor one that moves only the loop's neighbourhood can do);
// a corridor whose end repeats its start (a look-alike that must not be closed); the
// covisibility-consistency test; the options check.
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <memory>
#include <random>

#include "slam/core/error.hpp"
#include "slam/eval/trajectory_error.hpp"
#include "slam/loop/detection.hpp"
#include "slam/loop/loop_closer.hpp"
#include "slam/loop/verification.hpp"
#include "tests/slam/support/slam_test_support.hpp"

namespace coloc::slam::loop {
namespace {

struct Scene {
  std::vector<Eigen::Vector3d> world;
  std::vector<features::Descriptor> descriptors;
};

// Keyframes at the true poses, seen by the map through drift(k) (drifted_world_from_world):
// their poses and the points they create are drifted. A keyframe re-uses the points created by
// the last `track_window` keyframes (what tracking would match); older ones are created again,
// as a drifting tracker does when it comes back to a place. The BoW database stays empty: a
// keyframe enters it when it is handed to the closer (as local mapping does).
std::vector<KeyframeId> build_map(map::SharedMap& shared, const Scene& scene,
                                  const std::vector<SE3>& truth,
                                  const std::function<SE3(int)>& drift, int track_window) {
  map::Map& m = shared.map;
  std::vector<MapPointId> point_of(scene.world.size());
  std::vector<int> created_by(scene.world.size(), -1);
  std::vector<KeyframeId> ids;
  for (int k = 0; k < static_cast<int>(truth.size()); ++k) {
    auto pk = test_support::projected_keyframe(m, scene.world, scene.descriptors,
                                               truth[static_cast<std::size_t>(k)], true);
    map::Keyframe& kf = pk.keyframe;
    const SE3 d = drift(k);
    kf.frame.timestamp = k;
    kf.frame.cam_from_world = truth[static_cast<std::size_t>(k)] * d.inverse();
    test_support::vocabulary().transform(kf.frame.features.descriptors, kf.frame.bow,
                                         kf.frame.feature_vector);
    for (std::size_t i = 0; i < scene.world.size(); ++i) {
      const int kp = pk.keypoint_of_point[i];
      if (kp < 0) continue;
      const double z = (truth[static_cast<std::size_t>(k)] * scene.world[i]).z();
      kf.frame.u_right[static_cast<std::size_t>(kp)] =
          static_cast<float>(kf.frame.features.keypoints[static_cast<std::size_t>(kp)].ux -
                             40.0 / z);  // exact, not read at the rounded pixel
      kf.frame.depth[static_cast<std::size_t>(kp)] = static_cast<float>(z);
      if (created_by[i] >= k - track_window && point_of[i].valid() && m.point(point_of[i]))
        kf.frame.points[static_cast<std::size_t>(kp)] = point_of[i];
    }
    const KeyframeId id = m.add_keyframe(std::move(pk.keyframe)).id;
    const map::Keyframe& added = *m.keyframe(id);
    for (std::size_t i = 0; i < scene.world.size(); ++i) {
      const int kp = pk.keypoint_of_point[i];
      if (kp < 0 || added.frame.points[static_cast<std::size_t>(kp)].valid()) continue;
      point_of[i] = m.add_point(d * scene.world[i], id, static_cast<std::uint32_t>(kp)).id;
      created_by[i] = k;
    }
    for (MapPointId p : m.keyframe(id)->frame.points)
      if (p.valid()) m.update_point(p);
    m.update_connections(id);
    ids.push_back(id);
  }
  return ids;
}

// Points on a cylinder wall (radius 6 m) round a ring walk (radius 3 m, looking outwards).
Scene ring_scene() {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> angle(0.0, 2.0 * M_PI), height(-1.2, 1.2);
  Scene s;
  for (int i = 0; i < 2500; ++i) {
    const double a = angle(rng);
    s.world.emplace_back(6.0 * std::cos(a), height(rng), 6.0 * std::sin(a));
  }
  s.descriptors = test_support::random_descriptors(s.world.size(), 11);
  return s;
}

// Keyframe k of a ring of n per turn: at angle 2 pi k / n, optical axis outwards.
SE3 ring_pose(int k, int n) {
  const double a = 2.0 * M_PI * k / n;
  const Eigen::Vector3d centre(3.0 * std::cos(a), 0.0, 3.0 * std::sin(a));
  const Eigen::Vector3d z(std::cos(a), 0.0, std::sin(a)), y(0.0, 1.0, 0.0);
  Eigen::Matrix3d world_from_cam;
  world_from_cam << y.cross(z), y, z;
  return SE3(SO3(Eigen::Quaterniond(world_from_cam)), centre).inverse();
}

Trajectory keyframe_trajectory(const map::Map& m, const std::vector<KeyframeId>& ids) {
  Trajectory t;
  for (KeyframeId id : ids)
    if (const map::Keyframe* kf = m.keyframe(id))
      t.push_back({kf->frame.timestamp, kf->cam_from_world().inverse()});
  return t;
}

constexpr int kPerTurn = 40;
constexpr int kRingKeyframes = kPerTurn + 8;  // one turn and 8 keyframes into the second

// Drift grows linearly along the walk: 0.25 m and 0.04 rad after one turn.
SE3 ring_drift(int k) {
  const double f = static_cast<double>(k) / kPerTurn;
  return SE3::exp((Vector6d() << 0.2 * f, 0.05 * f, -0.15 * f, 0.0, 0.04 * f, 0.01 * f).finished());
}

std::vector<SE3> ring_truth() {
  std::vector<SE3> truth;
  for (int k = 0; k < kRingKeyframes; ++k)
    truth.push_back(ring_pose(k, kPerTurn));
  return truth;
}

Trajectory truth_trajectory(const std::vector<SE3>& truth) {
  Trajectory t;
  for (std::size_t k = 0; k < truth.size(); ++k)
    t.push_back({static_cast<double>(k), truth[k].inverse()});
  return t;
}

LoopStats run_closer(map::SharedMap& shared, const std::vector<KeyframeId>& ids,
                     LoopOptions options, bool wait_for_ba) {
  LoopCloser closer(shared, options);
  closer.start(nullptr);
  for (KeyframeId id : ids) {
    {
      std::lock_guard lock(shared.mutex);
      shared.database.add(id.value(), shared.map.keyframe(id)->frame.bow);
    }
    closer.push({id, {}});
    closer.wait_idle();  // one at a time, as in sequential mode
  }
  if (wait_for_ba) closer.wait_global_ba();
  closer.stop();
  return closer.stats();
}

TEST(LoopClosing, CorrectsADriftedRing) {
  map::SharedMap shared;
  const std::vector<SE3> truth = ring_truth();
  const std::vector<KeyframeId> ids = build_map(shared, ring_scene(), truth, ring_drift, 3);
  const Trajectory gt = truth_trajectory(truth);
  const double before =
      eval::compute_ate(gt, keyframe_trajectory(shared.map, ids)).translation.rmse;
  ASSERT_GT(before, 0.05);  // the drift is there to be corrected

  LoopOptions options;
  options.global_ba = false;
  const LoopStats stats = run_closer(shared, ids, options, false);
  ASSERT_GE(stats.loops.size(), 1u);
  const LoopRecord& loop = stats.loops.front();
  EXPECT_GE(loop.current.value(), static_cast<std::uint64_t>(kPerTurn));
  EXPECT_LT(loop.candidate.value(), 8u);
  EXPECT_GE(loop.inliers, 40);
  EXPECT_GT(loop.correction_m, 0.1);
  // Spread over the whole ring by the essential graph: every keyframe near the truth, which
  // leaving the map as it was (before) or moving only the loop's neighbourhood cannot give.
  const eval::AteResult after = eval::compute_ate(gt, keyframe_trajectory(shared.map, ids));
  // (A pose graph spreads a drift that is not constant in each camera's frame only roughly:
  // 12 cm -> under 3 cm here; the global BA test below gets the rest.)
  EXPECT_LT(after.translation.rmse, 0.035) << "before " << before;
  EXPECT_LT(after.translation.max, 0.06);
  EXPECT_EQ(test_support::map_problem(shared.map), "");
  const map::Keyframe* a = shared.map.keyframe(loop.current);
  const map::Keyframe* b = shared.map.keyframe(loop.candidate);
  ASSERT_TRUE(a && b);
  EXPECT_TRUE(a->loop_edges.count(loop.candidate) && b->loop_edges.count(loop.current));
  // Duplicates of the old side were merged: the loop keyframe shares points with the old one.
  EXPECT_TRUE(a->covisibility.count(loop.candidate) || b->covisibility.count(loop.current));
}

TEST(LoopClosing, BackgroundGlobalBaRefinesTheCorrectedRing) {
  map::SharedMap shared;
  const std::vector<SE3> truth = ring_truth();
  const std::vector<KeyframeId> ids = build_map(shared, ring_scene(), truth, ring_drift, 3);
  LoopOptions options;
  options.global_ba = true;
  const LoopStats stats = run_closer(shared, ids, options, true);
  ASSERT_GE(stats.loops.size(), 1u);
  ASSERT_GE(stats.global_ba_runs, 1);
  EXPECT_EQ(stats.global_ba_aborted, 0);
  // Exact observations: the BA brings the map to the truth up to millimetres.
  const eval::AteResult after =
      eval::compute_ate(truth_trajectory(truth), keyframe_trajectory(shared.map, ids));
  EXPECT_LT(after.translation.rmse, 0.005);
  EXPECT_EQ(test_support::map_problem(shared.map), "");
}

// A straight walk past a wall whose far end repeats its start (same points, same descriptors,
// 20 m further): appearance and local geometry agree perfectly, only the size of the implied
// correction tells the places apart.
TEST(LoopClosing, RejectsALookAlikePlace) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> x(-3.0, 24.0), y(-1.4, 1.4), dz(-0.3, 0.3);
  Scene s;
  for (int i = 0; i < 2500; ++i) {
    Eigen::Vector3d p(x(rng), y(rng), 3.0 + dz(rng));
    if (p.x() > 3.0 && p.x() < 18.0) s.world.push_back(p);
    if (p.x() <= 3.0) s.world.push_back(p);
  }
  s.descriptors = test_support::random_descriptors(s.world.size(), 21);
  const std::size_t n = s.world.size();
  for (std::size_t i = 0; i < n; ++i) {
    if (s.world[i].x() > 3.0) continue;
    s.world.push_back(s.world[i] + Eigen::Vector3d(21.0, 0.0, 0.0));  // the look-alike
    s.descriptors.push_back(s.descriptors[i]);
  }
  std::vector<SE3> truth;
  for (int k = 0; k <= 44; ++k)
    truth.push_back(SE3(SO3(), Eigen::Vector3d(-0.5 * k, 0.0, 0.0)));  // camera at x = 0.5 k
  map::SharedMap shared;
  const std::vector<KeyframeId> ids = build_map(
      shared, s, truth, [](int) { return SE3(); }, 3);
  const Trajectory before = keyframe_trajectory(shared.map, ids);

  const LoopStats stats = run_closer(shared, ids, LoopOptions{}, false);
  EXPECT_TRUE(stats.loops.empty());
  // Not vacuous: the look-alike reached verification and was refused for its correction.
  EXPECT_GE(stats.rejected_aliasing, 1);
  const Trajectory after = keyframe_trajectory(shared.map, ids);
  ASSERT_EQ(after.size(), before.size());
  for (std::size_t k = 0; k < after.size(); ++k)
    EXPECT_LT(translation_distance(after[k].world_from_cam, before[k].world_from_cam), 1e-9);
}

TEST(LoopDetection, NeedsConsecutiveConfirmations) {
  map::SharedMap shared;
  const std::vector<SE3> truth = ring_truth();
  const std::vector<KeyframeId> ids = build_map(shared, ring_scene(), truth, ring_drift, 3);
  LoopOptions options;
  options.min_consistency = 3;
  LoopDetector detector(options);
  for (KeyframeId id : ids)
    shared.database.add(id.value(), shared.map.keyframe(id)->frame.bow);
  const auto detect = [&](int k) {
    return detector.detect(shared.map, shared.database, ids[static_cast<std::size_t>(k)]);
  };
  // Keyframes kPerTurn.. revisit the start: candidates each time, but only the fourth in a row
  // is consistent enough.
  for (int k = kPerTurn; k < kPerTurn + 3; ++k) {
    const Detection d = detect(k);
    EXPECT_GE(d.raw_candidates, 1u) << k;
    EXPECT_TRUE(d.consistent.empty()) << k;
  }
  const Detection fourth = detect(kPerTurn + 3);
  ASSERT_EQ(fourth.consistent.size(), 1u);
  EXPECT_LT(fourth.consistent.front().keyframe.value(), 8u);
  EXPECT_EQ(fourth.consistent.front().consistency, 3);
  // A break in the chain (a keyframe whose candidates lie elsewhere) starts the count again.
  detector.reset();
  detect(kPerTurn);
  detect(kPerTurn + 1);
  detect(kPerTurn / 2);  // half a turn away: the start is not among its candidates
  EXPECT_TRUE(detect(kPerTurn + 2).consistent.empty());
  EXPECT_TRUE(detect(kPerTurn + 3).consistent.empty());
}

// A corridor wall papered with a 2 m tile (the same points and descriptors every 2 m, 1.3 m
// from the camera, so one view spans less than a period) and a few unique things in front of
// it. The camera walks 20 m along it (keyframes every 0.5 m, no drift) and back, drifting by
// `drift_per_keyframe` along the wall per keyframe of the way back.
struct Corridor {
  map::SharedMap shared;
  std::vector<KeyframeId> ids;
  std::vector<SE3> truth;
};

std::unique_ptr<Corridor> papered_corridor(double drift_per_keyframe) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> tile_x(0.0, 2.0), y(-0.9, 0.9), dz(-0.15, 0.15);
  std::uniform_real_distribution<double> x(-2.0, 22.0), near_z(0.8, 1.0);
  Scene s;
  std::vector<Eigen::Vector3d> tile;
  for (int i = 0; i < 200; ++i)
    tile.emplace_back(tile_x(rng), y(rng), 1.3 + dz(rng));
  const auto tile_descriptors = test_support::random_descriptors(tile.size(), 31);
  for (int period = -1; period <= 11; ++period)
    for (std::size_t i = 0; i < tile.size(); ++i) {
      s.world.push_back(tile[i] + Eigen::Vector3d(2.0 * period, 0.0, 0.0));
      s.descriptors.push_back(tile_descriptors[i]);
    }
  const std::size_t papered = s.world.size();
  for (int i = 0; i < 240; ++i)  // about 10 a view
    s.world.emplace_back(x(rng), y(rng), near_z(rng));
  const auto unique = test_support::random_descriptors(s.world.size() - papered, 32);
  s.descriptors.insert(s.descriptors.end(), unique.begin(), unique.end());

  auto c = std::make_unique<Corridor>();
  for (int k = 0; k <= 40; ++k)
    c->truth.push_back(SE3(SO3(), Eigen::Vector3d(-0.5 * k, 0.0, 0.0)));
  for (int k = 39; k >= 0; --k)
    c->truth.push_back(SE3(SO3(), Eigen::Vector3d(-0.5 * k - 0.1, 0.0, 0.0)));
  c->ids = build_map(
      c->shared, s, c->truth,
      [drift_per_keyframe](int k) {
        return SE3(SO3(), Eigen::Vector3d(drift_per_keyframe * std::max(0, k - 40), 0.0, 0.0));
      },
      3);
  return c;
}

// Verification of keyframe `current` (of the way back) against `candidate` (of the way out),
// with a drift bound wide enough for the 2 m period (as 184 m of path allowed at the twin
// site) and without depth: only the current-pose hypothesis can tell the period.
LoopVerification verify_in(const Corridor& c, int current, int candidate, bool current_pose) {
  LoopOptions o;
  o.max_drift_per_m = 1.0;
  o.current_pose_hypothesis = current_pose;
  std::mt19937 rng(5);
  return verify_loop(c.shared.map, c.ids[static_cast<std::size_t>(current)],
                     c.ids[static_cast<std::size_t>(candidate)], o, rng, nullptr);
}

TEST(LoopVerification, CurrentPoseHypothesisCatchesARepeatingTextureShiftedByOnePeriod) {
  const auto c = papered_corridor(0.003);
  // Keyframe 61 is back at x = 9.6 m (6 cm of drift); keyframe 23 saw x = 11.5 m on the way
  // out: the same paper one period on, other unique points.
  const int current = 61, alias = 23;
  ASSERT_NEAR(c->truth[current].inverse().translation().x(), 9.6, 1e-9);
  const LoopVerification shifted = verify_in(*c, current, alias, false);
  // Not vacuous: without the hypothesis the paper verifies the place 2 m off.
  ASSERT_TRUE(shifted.accepted) << shifted.rejection;
  EXPECT_NEAR(shifted.correction_m, 2.0, 0.15);

  const LoopVerification v = verify_in(*c, current, alias, true);
  ASSERT_TRUE(v.accepted) << v.rejection;
  EXPECT_GE(v.current_pose_inliers, LoopOptions{}.min_inliers);
  EXPECT_NEAR(v.hypothesis_moved_m, 2.0, 0.15);
  EXPECT_LT(v.correction_m, 0.1);
  // The pose asserted is the true one (the candidate's side of the map did not drift).
  EXPECT_LT(translation_distance(v.corrected_cam_from_world.inverse(), c->truth[current].inverse()),
            0.02);
}

TEST(LoopVerification, TrueLoopAfterDriftBeyondTheSearchKeepsItsHypothesis) {
  const auto c = papered_corridor(0.02);                   // 0.42 m of drift at keyframe 61
  const LoopVerification v = verify_in(*c, 61, 19, true);  // keyframe 19 saw x = 9.5 m
  ASSERT_TRUE(v.accepted) << v.rejection;
  EXPECT_EQ(v.hypothesis_moved_m, 0.0);
  EXPECT_NEAR(v.correction_m, 0.42, 0.05);
  EXPECT_LT(translation_distance(v.corrected_cam_from_world.inverse(), c->truth[61].inverse()),
            0.02);
}

// The default drift bounds against loops measured on the twin building and fr1/rpy (the
// corrections their `loop closed` log lines gave): every true one passes, the look-alike that
// failed a building run does not.
TEST(LoopPlausibility, DefaultBoundsPassTrueLoopsAndRejectTheBuildingsLookAlike) {
  const LoopOptions o;
  EXPECT_TRUE(plausible_correction(0.266, 0.0062, 85.05, o));  // building, largest true
  EXPECT_TRUE(plausible_correction(0.087, 0.0159, 84.83, o));
  EXPECT_TRUE(plausible_correction(0.108, 0.0664, 0.26, o));  // fr1/rpy
  EXPECT_TRUE(plausible_correction(0.108, 0.0540, 0.27, o));
  double allowed_m = 0.0, allowed_rad = 0.0;
  EXPECT_FALSE(plausible_correction(1.954, 0.0079, 82.77, o, &allowed_m, &allowed_rad));
  EXPECT_NEAR(allowed_m, 0.12 + 0.015 * 82.77, 1e-12);
  EXPECT_NEAR(allowed_rad, 0.1 + 0.005 * 82.77, 1e-12);
}

TEST(LoopOptions, CheckNamesTheField) {
  LoopOptions o;
  EXPECT_NO_THROW(o.check());
  o.min_inliers = 5;
  try {
    o.check();
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("min_inliers"), std::string::npos);
  }
  LoopOptions p;
  p.max_drift_per_m = -1.0;
  EXPECT_THROW(p.check(), Error);
}

}  // namespace
}  // namespace coloc::slam::loop
