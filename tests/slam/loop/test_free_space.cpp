// The free-space test on depth images ray-cast from boxes: two views of one room agree (even
// through lens distortion and from another position); a look-alike room, the same walls with
// the cupboard elsewhere, does not, though the walls alone would match.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "slam/core/error.hpp"
#include "slam/dataset/sequence.hpp"
#include "slam/loop/free_space.hpp"
#include "slam/loop/loop_options.hpp"
#include "tests/testing/cameras.hpp"
#include "tests/testing/data.hpp"

namespace coloc::slam::loop {
namespace {

struct Box {
  Eigen::Vector3d min, max;
};

// A room seen from inside (its walls) with solid boxes in it.
struct Room {
  Box walls;
  std::vector<Box> furniture;
};

// Entry distance of a ray into a box (slab method); infinity when missed.
double enter(const Box& b, const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  double t0 = 0.0, t1 = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    const double ta = (b.min[a] - o[a]) / d[a], tb = (b.max[a] - o[a]) / d[a];
    t0 = std::max(t0, std::min(ta, tb));
    t1 = std::min(t1, std::max(ta, tb));
  }
  return t0 <= t1 && t0 > 0.0 ? t0 : std::numeric_limits<double>::infinity();
}

// Exit distance of a ray from inside a box.
double leave(const Box& b, const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  double t = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a)
    t = std::min(t, std::max((b.min[a] - o[a]) / d[a], (b.max[a] - o[a]) / d[a]));
  return t;
}

// A real lens (TUM fr1's, strong radial distortion): the test must not mistake distortion for
// space.
PinholeCamera camera() {
  return testing::tum_fr1_camera();
}

map::KeyframeDepth render(const Room& room, const SE3& cam_from_world) {
  const PinholeCamera c = camera();
  const SE3 world_from_cam = cam_from_world.inverse();
  const Eigen::Vector3d o = world_from_cam.translation();
  std::vector<float> depth(static_cast<std::size_t>(c.width * c.height));
  for (int v = 0; v < c.height; ++v) {
    for (int u = 0; u < c.width; ++u) {
      const Eigen::Vector3d ray_cam = unproject(Camera(c), Eigen::Vector2d(u, v));
      const Eigen::Vector3d d = world_from_cam.so3() * ray_cam;
      double t = leave(room.walls, o, d);
      for (const Box& b : room.furniture)
        t = std::min(t, enter(b, o, d));
      depth[static_cast<std::size_t>(v * c.width + u)] = static_cast<float>(t * ray_cam.z());
    }
  }
  return map::downsample_depth(depth.data(), c.width, c.height, static_cast<std::size_t>(c.width),
                               4);
}

// Looking along +z from 1 m inside the room's front wall.
SE3 pose(double x, double yaw_deg) {
  const SO3 world_from_cam(
      Eigen::Quaterniond(Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitY())));
  return SE3(world_from_cam, Eigen::Vector3d(x, 0.0, 0.0)).inverse();
}

Room room_with_cupboard_at(double x) {
  return {{{-3.0, -1.5, -1.0}, {3.0, 1.2, 4.0}},
          {{{x - 0.6, -1.0, 2.0}, {x + 0.6, 1.2, 2.6}}, {{-2.9, 0.4, 3.0}, {-2.0, 1.2, 3.9}}}};
}

FreeSpaceCount both_ways(const map::KeyframeDepth& a, const map::KeyframeDepth& b,
                         const SE3& b_from_a, const Camera& cam = camera()) {
  const FreeSpaceOptions o;
  FreeSpaceCount c = compare_depth(depth_samples(a, cam, o), b, b_from_a, cam, o);
  c += compare_depth(depth_samples(b, cam, o), a, b_from_a.inverse(), cam, o);
  return c;
}

TEST(FreeSpace, TwoViewsOfOneRoomAgree) {
  const Room room = room_with_cupboard_at(0.0);
  const SE3 a = pose(0.0, 0.0), b = pose(0.4, -12.0);
  const FreeSpaceCount c = both_ways(render(room, a), render(room, b), b * a.inverse());
  EXPECT_GT(c.compared(), 3000);
  EXPECT_GT(c.occluded, 0);  // the cupboard hides a different part of the wall from each
  EXPECT_LT(c.violation(), 0.01) << c.violate << " of " << c.compared();
}

TEST(FreeSpace, ALookAlikeRoomViolatesTheOthersFreeSpace) {
  // The same walls (which is all a wall texture shared by two rooms would match) with the
  // cupboard 1.6 m to the side.
  const SE3 a = pose(0.0, 0.0);
  const FreeSpaceCount c = both_ways(render(room_with_cupboard_at(0.0), a),
                                     render(room_with_cupboard_at(1.6), a), SE3());
  EXPECT_GT(c.violation(), LoopOptions{}.max_free_space_violation)
      << c.violate << " of " << c.compared();
  // The walls still agree (a third of the samples): the evidence is the cupboard, not a broken
  // comparison.
  EXPECT_GT(c.agree, c.compared() / 3);
}

TEST(FreeSpace, AWrongPoseOfTheSameRoomViolates) {
  // The right room placed 0.5 m off: what a loop verified on a repeated pattern would assert.
  const Room room = room_with_cupboard_at(0.0);
  const SE3 a = pose(0.0, 0.0), b = pose(0.4, -12.0);
  const SE3 wrong = SE3(SO3(), Eigen::Vector3d(0.0, 0.0, 0.5)) * b * a.inverse();
  const FreeSpaceCount c = both_ways(render(room, a), render(room, b), wrong);
  EXPECT_GT(c.violation(), LoopOptions{}.max_free_space_violation)
      << c.violate << " of " << c.compared();
}

TEST(FreeSpace, ViewsThatDoNotOverlapCompareNothing) {
  const Room room = room_with_cupboard_at(0.0);
  const SE3 a = pose(0.0, 0.0), b = pose(0.0, 180.0);
  const FreeSpaceCount c = both_ways(render(room, a), render(room, b), b * a.inverse());
  EXPECT_EQ(c.compared(), 0);
  EXPECT_EQ(c.violation(), 0.0);
}

// Real depth (7-Scenes, Kinect, colour and depth not registered) at the pseudo ground truth's
// poses: views 0.3-1 s apart agree; the same pair asserted 0.3 m off along the view, as a
// look-alike would be, does not.
TEST(FreeSpace, RealViewsAgreeAtTheTruePoseOnly) {
  COLOC_REQUIRE_DATA(dir, "sevenscenes_600f");
  const auto sequence = dataset::open_sequence(dir);
  ASSERT_TRUE(sequence->camera());
  const Camera cam = *sequence->camera();
  const Trajectory& truth = sequence->ground_truth();
  ASSERT_EQ(truth.size(), sequence->size());
  const auto depth_of = [&](std::size_t i) {
    const cv::Mat d = sequence->frame(i).depth;
    return map::downsample_depth(d.ptr<float>(), d.cols, d.rows, d.step1(), 4);
  };
  for (const auto& [i, j] : {std::pair<std::size_t, std::size_t>{0, 10}, {200, 230}, {400, 430}}) {
    const SE3 j_from_i = truth[j].world_from_cam.inverse() * truth[i].world_from_cam;
    const map::KeyframeDepth a = depth_of(i), b = depth_of(j);
    const FreeSpaceCount right = both_ways(a, b, j_from_i, cam);
    EXPECT_GT(right.compared(), 2000) << i << "-" << j;
    EXPECT_LT(right.violation(), 0.05)
        << i << "-" << j << ": " << right.violate << " of " << right.compared();
    const SE3 off = SE3(SO3(), Eigen::Vector3d(0.0, 0.0, -0.3)) * j_from_i;
    const FreeSpaceCount wrong = both_ways(a, b, off, cam);
    EXPECT_GT(wrong.violation(), LoopOptions{}.max_free_space_violation)
        << i << "-" << j << ": " << wrong.violate << " of " << wrong.compared();
  }
}

TEST(FreeSpace, OptionsCheckNamesTheField) {
  FreeSpaceOptions o;
  o.stride = 0;
  EXPECT_THROW(
      {
        try {
          o.check();
        } catch (const Error& e) {
          EXPECT_NE(std::string(e.what()).find("stride"), std::string::npos);
          throw;
        }
      },
      Error);
  LoopOptions l;
  l.max_free_space_violation = 1.5;
  EXPECT_THROW(l.check(), Error);
}

}  // namespace
}  // namespace coloc::slam::loop
