// Global bundle adjustment: from a perturbed map with exact observations it must recover the
// true keyframe poses and points (the first keyframe fixes the gauge); on a SLAM run it must
// lower the reprojection error and leave a consistent map.
#include <gtest/gtest.h>

#include <algorithm>
#include <opencv2/core.hpp>
#include <random>

#include "slam/eval/trajectory_error.hpp"
#include "slam/mapping/global_ba.hpp"
#include "slam/synthetic/synthetic_scene.hpp"
#include "slam/system/system.hpp"
#include "tests/slam/support/slam_test_support.hpp"

namespace coloc::slam::system {
namespace {

using synthetic::SyntheticFrame;
using synthetic::SyntheticRgbdScene;
using synthetic::SyntheticSceneOptions;

// Six keyframes (one a second, t = 0..5 s) observing 300 points, exactly, but with the poses
// (all but the first) and the points perturbed.
struct PerturbedMap {
  std::unique_ptr<map::SharedMap> shared = std::make_unique<map::SharedMap>();
  std::vector<Eigen::Vector3d> world;
  std::vector<SE3> truth;  // cam_from_world
  std::vector<MapPointId> ids;
  std::vector<KeyframeId> keyframes;
};

PerturbedMap perturbed_map() {
  PerturbedMap out;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  const auto geometry = test_support::test_geometry();
  std::vector<Eigen::Vector3d>& world = out.world;
  for (int i = 0; i < 300; ++i)
    world.emplace_back(1.5 * uni(rng), 1.0 * uni(rng), 2.75 + 1.25 * uni(rng));
  std::vector<SE3>& truth = out.truth;
  for (int k = 0; k < 6; ++k) {
    truth.push_back(SE3::exp((Vector6d() << 0.06 * k, 0.02 * std::sin(k), 0.03 * k,
                              0.02 * std::cos(k), 0.04 * k, 0.01 * k)
                                 .finished()));
  }
  map::Map& m = out.shared->map;
  std::vector<MapPointId>& ids = out.ids;
  ids.resize(world.size());
  std::vector<KeyframeId>& keyframes = out.keyframes;
  for (std::size_t k = 0; k < truth.size(); ++k) {
    features::OrbFeatures f;
    cv::Mat depth(480, 640, CV_32FC1, cv::Scalar(0.0f));
    std::vector<std::size_t> seen;
    for (std::size_t i = 0; i < world.size(); ++i) {
      const Eigen::Vector3d pc = truth[k] * world[i];
      const Eigen::Vector2d uv = geometry->project(pc);
      if (uv.x() < 1 || uv.y() < 1 || uv.x() > 638 || uv.y() > 478) continue;
      float& d = depth.at<float>(static_cast<int>(std::lround(uv.y())),
                                 static_cast<int>(std::lround(uv.x())));
      if (d > 0.0f) continue;  // two points on one pixel: keep the first
      d = static_cast<float>(pc.z());
      features::Keypoint kp;
      kp.x = kp.ux = static_cast<float>(uv.x());
      kp.y = kp.uy = static_cast<float>(uv.y());
      kp.level = static_cast<int>(i % 3);
      f.keypoints.push_back(kp);
      f.descriptors.push_back({});
      seen.push_back(i);
    }
    map::Keyframe kf;
    kf.id = m.next_keyframe_id();
    kf.frame = frame::Frame(FrameId(kf.id.value()), static_cast<double>(k), f, depth, geometry);
    // Depth is read at the rounded pixel: give each keypoint its exact virtual right coordinate.
    for (std::size_t j = 0; j < seen.size(); ++j)
      kf.frame.u_right[j] =
          static_cast<float>(f.keypoints[j].ux - 40.0 / (truth[k] * world[seen[j]]).z());
    const Vector6d noise = (Vector6d() << 0.02 * uni(rng), 0.02 * uni(rng), 0.02 * uni(rng),
                            0.02 * uni(rng), 0.02 * uni(rng), 0.02 * uni(rng))
                               .finished();
    kf.frame.cam_from_world = k == 0 ? truth[k] : SE3::exp(noise) * truth[k];
    for (std::size_t j = 0; j < seen.size(); ++j)
      if (ids[seen[j]].valid()) kf.frame.points[j] = ids[seen[j]];
    const KeyframeId id = m.add_keyframe(std::move(kf)).id;
    keyframes.push_back(id);
    for (std::size_t j = 0; j < seen.size(); ++j) {
      if (ids[seen[j]].valid()) continue;
      const Eigen::Vector3d off(0.03 * uni(rng), 0.03 * uni(rng), 0.03 * uni(rng));
      ids[seen[j]] = m.add_point(world[seen[j]] + off, id, static_cast<std::uint32_t>(j)).id;
    }
    m.update_connections(id);
  }
  for (const auto& [id, p] : m.points())
    m.update_point(id);
  return out;
}

TEST(GlobalBundleAdjustment, RecoversPerturbedPosesAndPoints) {
  const auto& [shared, world, truth, ids, keyframes] = perturbed_map();
  const map::Map& m = shared->map;
  const mapping::GlobalBaReport report = mapping::global_bundle_adjustment(*shared);
  EXPECT_EQ(report.keyframes, truth.size());
  EXPECT_EQ(report.outliers, 0u);
  EXPECT_GT(report.initial_rms_px, 5.0);
  EXPECT_LT(report.final_rms_px, 1e-3);
  for (std::size_t k = 0; k < truth.size(); ++k) {
    const Vector6d err = (m.keyframe(keyframes[k])->cam_from_world() * truth[k].inverse()).log();
    EXPECT_LT(err.head<3>().norm(), 1e-4) << "keyframe " << k;
    EXPECT_LT(err.tail<3>().norm(), 1e-5) << "keyframe " << k;
  }
  for (std::size_t i = 0; i < world.size(); ++i) {
    if (const map::MapPoint* p = ids[i].valid() ? m.point(ids[i]) : nullptr) {
      if (p->observations.size() >= 2) {
        EXPECT_LT((p->position - world[i]).norm(), 1e-4);
      }
    }
  }
  EXPECT_EQ(test_support::map_problem(m), "");
}

// A continued map: keyframes 0-2 came from an earlier recording, 3-5 from this one, whose IMU
// log covers all six timestamps (another recording's clock may well overlap this one's). Only
// 3-5 may take gravity from this log, and the gyro only between 4 and 3, 5 and 4. The camera stands
// at each keyframe's pose around its second: the accelerometer reads gravity, the gyro nothing.
TEST(GlobalBundleAdjustment, TheImuTiesOnlyTheKeyframesOfItsRecording) {
  const std::vector<SE3> truth = perturbed_map().truth;
  const Eigen::Vector3d up_world(0.0, -1.0, 0.0);
  Trajectory frames;
  std::vector<ImuSample> imu;
  for (int i = -200; i <= 1300; ++i) {
    const double t = 0.005 * i;
    const auto k = static_cast<std::size_t>(std::clamp(std::lround(t), 0L, 5L));
    imu.push_back({t, Eigen::Vector3d::Zero(), truth[k].so3() * (9.81 * up_world)});
    if (i % 10 == 0) frames.push_back({t, truth[k].inverse()});
  }
  mapping::GravityOptions gravity_options;
  gravity_options.half_window = 0.3;  // within each keyframe's stand
  const mapping::GravityMeasurements gravity(imu, SE3(), frames, gravity_options);
  const mapping::GyroMeasurements gyro(imu, SE3());

  const PerturbedMap all = perturbed_map();
  const mapping::GlobalBaReport one_recording =
      mapping::global_bundle_adjustment(*all.shared, {}, {.gravity = &gravity, .gyro = &gyro});
  EXPECT_EQ(one_recording.gravity_keyframes, 6u);
  EXPECT_EQ(one_recording.gyro_pairs, 5u);

  const PerturbedMap continued = perturbed_map();
  const mapping::GlobalBaReport second_recording = mapping::global_bundle_adjustment(
      *continued.shared, {},
      {.gravity = &gravity, .gyro = &gyro, .first_keyframe = continued.keyframes[3]});
  EXPECT_EQ(second_recording.gravity_keyframes, 3u);
  EXPECT_EQ(second_recording.gyro_pairs, 2u);
  EXPECT_EQ(second_recording.keyframes, 6u);  // all of them still adjusted by vision

  // Had the earlier recording stored its own measurements (here: this log's, as if it were
  // the earlier one's), they hold keyframes 0-2 too, with a bias of their own. No link joins
  // the recordings: 2 -> 3 goes when 3-5 are measured again as another recording.
  const PerturbedMap stored = perturbed_map();
  mapping::global_bundle_adjustment(*stored.shared, {}, {.gravity = &gravity, .gyro = &gyro});
  const mapping::GlobalBaReport both = mapping::global_bundle_adjustment(
      *stored.shared, {},
      {.gravity = &gravity, .gyro = &gyro, .first_keyframe = stored.keyframes[3]});
  EXPECT_EQ(both.gravity_keyframes, 6u);
  EXPECT_EQ(both.gyro_pairs, 4u);
  const map::Map& m = stored.shared->map;
  EXPECT_EQ(m.keyframe(stored.keyframes[1])->gravity->recording, stored.keyframes[0]);
  EXPECT_EQ(m.keyframe(stored.keyframes[4])->gravity->recording, stored.keyframes[3]);
  EXPECT_FALSE(m.keyframe(stored.keyframes[2])->gyro);
  EXPECT_EQ(m.keyframe(stored.keyframes[3])->gyro->next, stored.keyframes[4]);
}

TEST(GlobalBundleAdjustment, KeepsASlamMapConsistentAndAccurate) {
  SyntheticSceneOptions scene_options;
  scene_options.frames = 30;
  const SyntheticRgbdScene scene(scene_options);
  SystemOptions options;
  options.tracking.wait_for_sink = true;
  options.detect_markers = false;
  System slam(scene.settings(), test_support::vocabulary(), options);
  Trajectory truth;
  for (int i = 0; i < scene.size(); ++i) {
    const SyntheticFrame f = scene.frame(i);
    truth.push_back({f.timestamp, f.world_from_cam});
    slam.track(f.color, f.depth, f.timestamp);
  }
  const mapping::GlobalBaReport report = slam.optimize_map();
  EXPECT_GE(report.keyframes, 2u);
  EXPECT_LE(report.final_rms_px, report.initial_rms_px);
  EXPECT_LT(report.outliers, report.observations / 20);
  EXPECT_LT(eval::compute_ate(truth, slam.trajectory()).translation.rmse, 0.005);
  EXPECT_EQ(slam.with_map(test_support::map_problem), "");
}

}  // namespace
}  // namespace coloc::slam::system
