// The scan anchor (slam/localize/scan_anchor.hpp): depth images aligned to a scan's surface.
// Synthetic: a furnished room ray-cast from known poses. Real: 7-Scenes frames against a cloud
// fused from the recording's own (KinectFusion) poses.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/core.hpp>
#include <random>
#include <vector>

#include "slam/core/error.hpp"
#include "slam/dataset/sequence.hpp"
#include "slam/localize/scan_anchor.hpp"
#include "tests/testing/data.hpp"

namespace coloc::slam::localize {
namespace {

// Axis-aligned boxes; the room is the first, seen from inside.
struct Box {
  Eigen::Vector3d lo, hi;
};

std::vector<Box> furnished_room() {
  return {{{-2.0, -1.5, 0.0}, {2.0, 1.5, 2.5}},    // the room
          {{-0.6, -0.4, 0.0}, {0.6, 0.4, 0.75}},   // a table
          {{1.2, 0.8, 0.0}, {1.9, 1.4, 1.8}},      // a cupboard
          {{-1.9, -1.4, 0.0}, {-1.3, -0.9, 0.5}},  // a crate
          {{0.9, -1.45, 0.9}, {1.6, -1.2, 1.6}}};  // a shelf on the wall
}

// Ray-box intersection: the nearest hit distance along unit `d` from `o` (room: from inside).
double hit(const Box& b, const Eigen::Vector3d& o, const Eigen::Vector3d& d, bool inside) {
  double t0 = -1e9, t1 = 1e9;
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d[a]) < 1e-12) {
      if (o[a] < b.lo[a] || o[a] > b.hi[a]) return -1.0;
      continue;
    }
    double ta = (b.lo[a] - o[a]) / d[a], tb = (b.hi[a] - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  if (t0 > t1) return -1.0;
  return inside ? t1 : (t0 > 0.0 ? t0 : -1.0);
}

PinholeCamera camera() {
  PinholeCamera c;
  c.width = 320;
  c.height = 240;
  c.fx = c.fy = 290.0;
  c.cx = 160.0;
  c.cy = 120.0;
  return c;
}

cv::Mat render_depth(const std::vector<Box>& scene, const SE3& world_from_cam) {
  const PinholeCamera c = camera();
  cv::Mat depth(c.height, c.width, CV_32FC1, cv::Scalar(0.0f));
  for (int v = 0; v < c.height; ++v)
    for (int u = 0; u < c.width; ++u) {
      const Eigen::Vector3d ray_cam((u - c.cx) / c.fx, (v - c.cy) / c.fy, 1.0);
      const Eigen::Vector3d d = (world_from_cam.rotation() * ray_cam).normalized();
      double best = 1e9;
      for (std::size_t i = 0; i < scene.size(); ++i) {
        const double t = hit(scene[i], world_from_cam.translation(), d, i == 0);
        if (t > 0.0) best = std::min(best, t);
      }
      if (best < 1e8) depth.at<float>(v, u) = static_cast<float>(best / ray_cam.norm());
    }
  return depth;
}

// The boxes' faces sampled every `step` metres (the room's from inside).
std::vector<Eigen::Vector3f> sample_scene(const std::vector<Box>& scene, double step) {
  std::vector<Eigen::Vector3f> points;
  for (const Box& b : scene)
    for (int a = 0; a < 3; ++a)
      for (const double face : {b.lo[a], b.hi[a]}) {
        const int a1 = (a + 1) % 3, a2 = (a + 2) % 3;
        for (double s = b.lo[a1]; s <= b.hi[a1]; s += step)
          for (double t = b.lo[a2]; t <= b.hi[a2]; t += step) {
            Eigen::Vector3d p;
            p[a] = face;
            p[a1] = s;
            p[a2] = t;
            points.push_back(p.cast<float>());
          }
      }
  return points;
}

// A camera at `centre` looking at `target` (z forward, y down, the world's z up).
SE3 look_at(const Eigen::Vector3d& centre, const Eigen::Vector3d& target) {
  const Eigen::Vector3d z = (target - centre).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d r;
  r << x, y, z;
  return SE3(SO3::from_matrix(r), centre);
}

// `pose` turned by `radians` about its own centre and moved by `metres`, in random directions.
SE3 perturbed(const SE3& pose, double metres, double radians, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  const Eigen::Vector3d dt = Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized() * metres;
  const Eigen::Vector3d dr = Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized() * radians;
  SE3 out = pose * SE3(SO3::exp(dr), Eigen::Vector3d::Zero());
  out.translation() += dt;
  return out;
}

double angle_between(const SE3& a, const SE3& b) {
  return (a * b.inverse()).so3().log().norm();
}

TEST(ScanAnchor, RecoversThePoseFromACentimetreOffInAFurnishedRoom) {
  const std::vector<Box> scene = furnished_room();
  const ScanAnchor anchor(sample_scene(scene, 0.01));
  const DepthSampler sampler(camera(), 4);
  std::mt19937 rng(7);
  for (int i = 0; i < 6; ++i) {
    const double yaw = i * 1.05;
    const SE3 truth = look_at({1.2 * std::cos(yaw), 1.0 * std::sin(yaw), 1.5},
                              {-0.3 * std::cos(yaw), -0.3 * std::sin(yaw), 0.6});
    const cv::Mat depth = render_depth(scene, truth);
    const SE3 start = perturbed(truth, 0.06, 0.05, rng);
    const auto r = anchor.align(sampler.points(depth, 0.2, 6.0), start, start, true);
    ASSERT_TRUE(r) << "view " << i;
    EXPECT_LT((r->world_from_cam.translation() - truth.translation()).norm(), 0.002) << i;
    EXPECT_LT(angle_between(r->world_from_cam, truth), 0.002) << i;
    EXPECT_LT(r->rms_m, 0.002) << i;
    EXPECT_GT(r->conditioning, 0.01) << i;
  }
}

TEST(ScanAnchor, APlainWallHoldsTheDirectionsItCannotFix) {
  // Facing one wall from 1 m: depth fixes the distance to it and two tilts, nothing else; the
  // prior keeps the start there instead of sliding anywhere.
  const std::vector<Box> scene{{{-2.0, -1.5, 0.0}, {2.0, 1.5, 2.5}}};
  const ScanAnchor anchor(sample_scene(scene, 0.01));
  const DepthSampler sampler(camera(), 4);
  const SE3 truth = look_at({1.0, 0.0, 1.2}, {2.0, 0.0, 1.2});
  const SE3 start = SE3(SO3(), Eigen::Vector3d(0.03, 0.04, 0.0)) * truth;  // 3 cm off the wall
  const auto r =
      anchor.align(sampler.points(render_depth(scene, truth), 0.2, 6.0), start, start, true);
  ASSERT_TRUE(r);
  const Eigen::Vector3d c = r->world_from_cam.translation();
  EXPECT_NEAR(c.x(), 1.0, 0.002);   // the wall's normal: fixed by depth
  EXPECT_NEAR(c.y(), 0.04, 0.005);  // along the wall: held at the start
  EXPECT_LT(r->conditioning, 1e-3);
}

TEST(ScanAnchor, RefusesAScanOfAnotherPlace) {
  const std::vector<Box> scene = furnished_room();
  // Another room: turned by 90 degrees, other furniture.
  const std::vector<Box> other{{{-1.5, -2.0, 0.0}, {1.5, 2.0, 2.5}},
                               {{-1.4, 1.0, 0.0}, {-0.5, 1.9, 1.0}}};
  const ScanAnchor anchor(sample_scene(other, 0.01));
  const DepthSampler sampler(camera(), 4);
  const SE3 truth = look_at({1.2, 0.0, 1.5}, {-0.3, 0.0, 0.6});
  const auto r =
      anchor.align(sampler.points(render_depth(scene, truth), 0.2, 6.0), truth, truth, true);
  EXPECT_FALSE(r);
}

TEST(ScanAnchor, ScanWithoutSurfaceIsANamedError) {
  // Points 10 cm apart (a far, sparse scan): no neighbourhood holds enough of them for a plane.
  std::vector<Eigen::Vector3f> scattered;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j)
      for (int k = 0; k < 10; ++k)
        scattered.emplace_back(0.1f * i, 0.1f * j, 0.1f * k);
  try {
    const ScanAnchor anchor(scattered);
    FAIL() << "a scan of scattered points was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "scan");
  }
  ScanAnchorOptions o;
  o.tracking_gates.clear();
  EXPECT_THROW(o.check(), Error);
}

// 7-Scenes: colour and depth are not registered, and the poses are KinectFusion's, of the depth
// camera. A cloud fused from those poses is the "scan"; depth frames aligned to it from 5 cm
// and 3 degrees off land on the recording's own poses.
TEST(ScanAnchor, SevenScenesFramesLandOnTheirRecordedPoses) {
  COLOC_REQUIRE_DATA(dir, "sevenscenes_600f");
  const auto sequence = dataset::open_sequence(dir);
  const Camera cam = *sequence->camera();
  const DepthSampler dense(cam, 4);
  std::vector<Eigen::Vector3f> cloud;
  for (std::size_t i = 0; i < sequence->size(); i += 10) {
    const dataset::Frame f = sequence->frame(i);
    const SE3& world_from_cam = sequence->ground_truth()[i].world_from_cam;
    for (const Eigen::Vector3d& p : dense.points(f.depth, 0.2, 5.0))
      cloud.push_back((world_from_cam * p).cast<float>());
  }
  const ScanAnchor anchor(cloud);
  const DepthSampler sampler(cam, 8);
  std::mt19937 rng(11);
  std::vector<double> errors;
  for (std::size_t i = 5; i < sequence->size(); i += 30) {
    const SE3& truth = sequence->ground_truth()[i].world_from_cam;
    const SE3 start = perturbed(truth, 0.05, 0.05, rng);
    const auto r =
        anchor.align(sampler.points(sequence->frame(i).depth, 0.2, 5.0), start, start, true);
    ASSERT_TRUE(r) << "frame " << i;
    errors.push_back((r->world_from_cam.translation() - truth.translation()).norm());
  }
  std::sort(errors.begin(), errors.end());
  const double median = errors[errors.size() / 2];
  std::printf("7-Scenes, %zu frames from 5 cm / 2.9 deg: median %.1f mm, max %.1f mm\n",
              errors.size(), 1e3 * median, 1e3 * errors.back());
  EXPECT_LT(median, 0.015);
}

}  // namespace
}  // namespace coloc::slam::localize
