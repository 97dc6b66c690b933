#include <gtest/gtest.h>

#include "slam/map/map.hpp"
#include "tests/slam/support/slam_test_support.hpp"

namespace coloc::slam::map {
namespace {

using test_support::row_keyframe;

TEST(Map, ObservationsCovisibilityAndSpanningTreeStayConsistent) {
  Map map;
  const KeyframeId a = map.add_keyframe(row_keyframe(map, 40, {0, 0, 0})).id;
  std::vector<MapPointId> pts;
  for (std::uint32_t i = 0; i < 40; ++i) {
    pts.push_back(map.add_point(map.keyframe(a)->frame.unproject_world(i), a, i).id);
  }
  EXPECT_EQ(map.point_count(), 40u);
  // Keyframe b sees the first 30 points, c the last 20.
  Keyframe kb = row_keyframe(map, 40, {0.1, 0, 0});
  for (std::size_t i = 0; i < 30; ++i)
    kb.frame.points[i] = pts[i];
  const KeyframeId b = map.add_keyframe(std::move(kb)).id;
  Keyframe kc = row_keyframe(map, 40, {0.2, 0, 0});
  for (std::size_t i = 20; i < 40; ++i)
    kc.frame.points[i] = pts[i];
  const KeyframeId c = map.add_keyframe(std::move(kc)).id;
  map.update_connections(b);
  map.update_connections(c);
  EXPECT_EQ(map.keyframe(b)->covisibility.at(a), 30);
  EXPECT_EQ(map.keyframe(c)->covisibility.at(a), 20);
  EXPECT_EQ(map.keyframe(c)->covisibility.count(b), 0u);  // 10 shared points: below 15
  EXPECT_EQ(map.keyframe(a)->covisible_ordered.front(), b);
  EXPECT_EQ(map.keyframe(b)->parent, a);
  EXPECT_EQ(map.keyframe(c)->parent, a);  // strongest covisible when it joined
  EXPECT_EQ(map.point(pts[25])->observations.size(), 3u);
  EXPECT_EQ(map.weighted_observations(pts[25]), 6);  // with depth: counted twice

  // Erasing an observation updates both sides; a point left with one keyframe goes.
  map.erase_observation(pts[5], b);
  EXPECT_FALSE(map.point(pts[5]));
  EXPECT_FALSE(map.keyframe(a)->frame.points[5].valid());
  EXPECT_FALSE(map.keyframe(b)->frame.points[5].valid());

  // Merging: the point with more observations survives and takes the other's keyframes.
  map.replace_point(pts[35], pts[25]);
  EXPECT_FALSE(map.point(pts[35]));
  EXPECT_EQ(map.keyframe(c)->frame.points[35], MapPointId::invalid());  // c already saw 25

  // Erasing b re-attaches nothing (no children) and keeps its pose reachable via its parent.
  const SE3 pose_b = map.keyframe(b)->cam_from_world();
  map.erase_keyframe(b);
  EXPECT_FALSE(map.keyframe(b));
  EXPECT_FALSE(map.keyframe(a)->children.count(b));
  EXPECT_EQ(map.keyframe(a)->covisibility.count(b), 0u);
  const auto again = map.keyframe_pose(b);
  ASSERT_TRUE(again.has_value());
  EXPECT_LT(translation_distance(*again, pose_b), 1e-12);
  for (const auto& [id, p] : map.points()) {
    for (const auto& [k, idx] : p.observations) {
      ASSERT_TRUE(map.keyframe(k));
      EXPECT_EQ(map.keyframe(k)->frame.points[idx], id);
    }
  }
}

// The gyro measured the whole way from a through an erased b to c: a's link then reaches c, with
// the rotations composed and the bias Jacobian right to first order in the bias.
TEST(Map, ErasingAKeyframeChainsTheGyroLinkThroughIt) {
  Map map;
  std::vector<KeyframeId> ids;
  for (int k = 0; k < 4; ++k)
    ids.push_back(map.add_keyframe(row_keyframe(map, 20, {0.1 * k, 0, 0})).id);
  const KeyframeId recording = ids[0];
  const std::vector<GyroLink> links = {
      {recording, ids[1], SO3::exp({0.3, -0.1, 0.2}), Eigen::Matrix3d::Identity() * -0.2, 0.2},
      {recording, ids[2], SO3::exp({-0.2, 0.4, 0.1}),
       Eigen::Matrix3d::Identity() * -0.3 + SO3::hat({0.01, 0.02, -0.03}), 0.3},
      {recording, ids[3], SO3::exp({0.1, 0.1, -0.5}), Eigen::Matrix3d::Identity() * -0.1, 0.1}};
  for (std::size_t k = 0; k < links.size(); ++k)
    map.keyframe(ids[k])->gyro = links[k];

  map.erase_keyframe(ids[1]);
  const std::optional<GyroLink>& ac = map.keyframe(ids[0])->gyro;
  ASSERT_TRUE(ac);
  EXPECT_EQ(ac->next, ids[2]);
  EXPECT_EQ(ac->recording, recording);
  EXPECT_DOUBLE_EQ(ac->dt, 0.5);
  // With a bias b, each measured rotation is R exp(J b); the chained one must agree with the
  // product of the two to second order (a Jacobian merely added would be off to first order).
  const Eigen::Vector3d bias(1e-3, -0.5e-3, 1.5e-3);
  const auto corrected = [&](const GyroLink& l) {
    return l.cam_from_next * SO3::exp(l.bias_jacobian * bias);
  };
  EXPECT_LT(angular_distance(corrected(*ac), corrected(links[0]) * corrected(links[1])), 1e-6);
  EXPECT_GT(angular_distance(ac->cam_from_next *
                                 SO3::exp((links[0].bias_jacobian + links[1].bias_jacobian) * bias),
                             corrected(links[0]) * corrected(links[1])),
            5e-5);

  // The last keyframe has no link of its own: the one that led to it goes with it.
  map.erase_keyframe(ids[3]);
  EXPECT_FALSE(map.keyframe(ids[2])->gyro);
  EXPECT_TRUE(map.keyframe(ids[0])->gyro);
}

TEST(Map, PointStatisticsFollowObservations) {
  Map map;
  const KeyframeId a = map.add_keyframe(row_keyframe(map, 5, {0, 0, 0})).id;
  const MapPoint& p = map.add_point(map.keyframe(a)->frame.unproject_world(2), a, 2);
  // Straight ahead at 2 m, level 0: max distance 2 m, min = max / scale of the last level.
  EXPECT_NEAR(p.max_distance, (p.position).norm(), 1e-9);
  EXPECT_NEAR(p.min_distance, p.max_distance / 1.44, 1e-6);
  EXPECT_NEAR(p.normal.dot(p.position.normalized()), 1.0, 1e-12);
  EXPECT_EQ(p.descriptor, map.keyframe(a)->frame.features.descriptors[2]);
}

// The flat observation list behaves as the std::map it replaced: keyed, unique, ascending.
TEST(Map, ObservationsAreSortedByKeyframeAndUnique) {
  Observations o;
  for (std::uint64_t k : {7u, 3u, 11u, 5u})
    EXPECT_TRUE(o.emplace(KeyframeId(k), static_cast<std::uint32_t>(k * 10)).second);
  EXPECT_FALSE(o.emplace(KeyframeId(5), 99).second);  // kept the first, as std::map
  EXPECT_EQ(o.at(KeyframeId(5)), 50u);
  o[KeyframeId(9)] = 90;
  o[KeyframeId(3)] = 31;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> seen;
  for (const auto& [k, idx] : o)
    seen.emplace_back(k.value(), idx);
  const std::vector<std::pair<std::uint64_t, std::uint32_t>> expected{
      {3, 31}, {5, 50}, {7, 70}, {9, 90}, {11, 110}};
  EXPECT_EQ(seen, expected);
  EXPECT_EQ(o.count(KeyframeId(4)), 0u);
  EXPECT_EQ(o.find(KeyframeId(4)), o.end());
  EXPECT_THROW(o.at(KeyframeId(4)), std::out_of_range);
  o.erase(o.find(KeyframeId(3)));
  EXPECT_EQ(o.erase(KeyframeId(9)), 1u);
  EXPECT_EQ(o.erase(KeyframeId(9)), 0u);
  ASSERT_EQ(o.size(), 3u);
  EXPECT_EQ(o.begin()->first, KeyframeId(5));
  Observations copy = o;
  copy.shrink_to_fit();
  EXPECT_EQ(copy, o);
}

}  // namespace
}  // namespace coloc::slam::map
