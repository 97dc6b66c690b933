// Localization in a saved map, on a real map: a twin room walk mapped by the SLAM system and
// saved with the SQLite map database (localize_fixture.hpp), loaded and localized in.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <fstream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "slam/core/error.hpp"
#include "slam/localize/c_api.h"
#include "slam/localize/localizer.hpp"
#include "tests/slam/localize/localize_fixture.hpp"
#include "tests/slam/mapdb/map_compare.hpp"

namespace coloc::slam::localize {
namespace {

using test::angle_deg;
using test::fixture;

struct Inputs {
  std::unique_ptr<LocalizationMap> map;
  settings::Settings settings;
  std::unique_ptr<dataset::Sequence> sequence;
};

Inputs open_inputs() {
  Inputs in;
  in.map = load_localization_map(fixture().map, test_support::vocabulary());
  in.settings = settings::load_settings(fixture().sequence / "camera.yaml");
  dataset::SequenceOptions so;
  so.depth_scale = in.settings.depth->depth_map_factor;
  in.sequence = dataset::open_sequence(fixture().sequence, so);
  return in;
}

Localizer make_localizer(Inputs& in) {
  return Localizer(*in.map, test_support::vocabulary(), in.settings,
                   options_from_settings(in.settings));
}

LocalizationResult localize_frame(Localizer& l, const dataset::Sequence& s, std::size_t i,
                                  bool rgb_order = true) {
  const dataset::Frame f = s.frame(i);
  // Localizer::localize takes the camera's channel order (Camera.RGB), as `coloc localize` does.
  return l.localize(dataset::to_camera_order(f.color, rgb_order), f.depth, f.timestamp);
}

// The pose SLAM gave the frame at `t` while mapping (exact timestamp match).
std::optional<SE3> mapped_pose(const Trajectory& t, double time) {
  for (const auto& p : t)
    if (std::abs(p.timestamp - time) < 1e-4) return p.world_from_cam;
  return std::nullopt;
}

std::uint64_t file_hash(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::vector<char> buffer(1 << 16);
  std::uint64_t h = 1469598103934665603ULL;  // FNV-1a
  while (in.read(buffer.data(), static_cast<std::streamsize>(buffer.size())) || in.gcount() > 0) {
    for (std::streamsize i = 0; i < in.gcount(); ++i)
      h = (h ^ static_cast<unsigned char>(buffer[static_cast<std::size_t>(i)])) * 1099511628211ULL;
  }
  return h;
}

// Map -> save -> load -> localize the same walk: every frame localizes, each keyframe's frame
// lands on the keyframe's saved pose, and the whole walk on the trajectory SLAM mapped (a
// reported peer bug: localization after load drifting away from the mapping run).
TEST(Localizer, SameSequenceAgreesWithTheMappedTrajectory) {
  Inputs in = open_inputs();
  Localizer l = make_localizer(in);
  const auto& f = fixture();
  double kf_max = 0.0, kf_rot_max = 0.0, traj_sq = 0.0, traj_max = 0.0;
  int kf_checked = 0, traj_checked = 0;
  for (std::size_t i = 0; i < in.sequence->size(); ++i) {
    const LocalizationResult r = localize_frame(l, *in.sequence, i);
    ASSERT_NE(r.state, LocalizationState::kLost) << "frame " << i;
    EXPECT_EQ(r.state, i == 0 ? LocalizationState::kRelocalized : LocalizationState::kTracking);
    EXPECT_GT(r.inliers, 100) << "frame " << i;
    EXPECT_GT(r.reprojection_rms_px, 0.0);
    EXPECT_LT(r.reprojection_rms_px, 3.0) << "frame " << i;
    if (const auto kf = mapped_pose(f.keyframes, r.timestamp)) {
      kf_max = std::max(kf_max, (kf->translation() - r.world_from_cam.translation()).norm());
      kf_rot_max = std::max(kf_rot_max, angle_deg(*kf, r.world_from_cam));
      ++kf_checked;
    }
    if (const auto m = mapped_pose(f.mapped, r.timestamp)) {
      const double e = (m->translation() - r.world_from_cam.translation()).norm();
      traj_sq += e * e;
      traj_max = std::max(traj_max, e);
      ++traj_checked;
    }
  }
  EXPECT_GE(kf_checked, 5);
  EXPECT_LT(kf_max, 0.005) << "metres, keyframe frames vs their saved poses";
  EXPECT_LT(kf_rot_max, 0.3) << "degrees";
  ASSERT_GE(traj_checked + 2, static_cast<int>(in.sequence->size()));  // as SLAM tracked them
  EXPECT_LT(std::sqrt(traj_sq / traj_checked), 0.006) << "metres RMS vs the mapped trajectory";
  EXPECT_LT(traj_max, 0.02);
  const LocalizerStats& s = l.stats();
  EXPECT_EQ(s.localized, in.sequence->size());
  EXPECT_EQ(s.relocalizations, 1u);
  EXPECT_EQ(s.first_localized_frame, 0);
  std::cout << "keyframe frames: max " << 1e3 * kf_max << " mm, " << kf_rot_max
            << " deg; mapped trajectory RMS " << 1e3 * std::sqrt(traj_sq / traj_checked)
            << " mm, max " << 1e3 * traj_max << " mm; ms/frame median " << s.total_ms.quantile(0.5)
            << "\n";
}

// The first frame is anywhere in the map: it relocalizes at once and tracking goes on from it.
TEST(Localizer, ColdStartMidSequence) {
  Inputs in = open_inputs();
  for (std::size_t start : {60u, 130u}) {
    Localizer l = make_localizer(in);
    for (std::size_t i = start; i < start + 10; ++i) {
      const LocalizationResult r = localize_frame(l, *in.sequence, i);
      ASSERT_EQ(r.state,
                i == start ? LocalizationState::kRelocalized : LocalizationState::kTracking)
          << "start " << start << " frame " << i;
      const auto m = mapped_pose(fixture().mapped, r.timestamp);
      ASSERT_TRUE(m);
      EXPECT_LT((m->translation() - r.world_from_cam.translation()).norm(), 0.02);
      EXPECT_LT(angle_deg(*m, r.world_from_cam), 1.0);
    }
    EXPECT_EQ(l.stats().first_localized_frame, 0);
    EXPECT_EQ(l.stats().relocalizations, 1u);
  }
}

// Covered camera (black frames): lost, and relocalized when the view comes back somewhere else
// on the walk; the pose after the jump is right again.
TEST(Localizer, LostThenRelocalizedAfterAJump) {
  Inputs in = open_inputs();
  Localizer l = make_localizer(in);
  for (std::size_t i = 0; i < 20; ++i)
    ASSERT_NE(localize_frame(l, *in.sequence, i).state, LocalizationState::kLost);
  const dataset::Frame f = in.sequence->frame(20);
  const cv::Mat black = cv::Mat::zeros(f.color.size(), f.color.type());
  const cv::Mat no_depth = cv::Mat::zeros(f.depth.size(), f.depth.type());
  for (int k = 0; k < 3; ++k) {
    const LocalizationResult r = l.localize(black, no_depth, f.timestamp + 0.01 * k);
    EXPECT_EQ(r.state, LocalizationState::kLost);
    EXPECT_EQ(r.inliers, 0);
  }
  const std::size_t jump = 150;
  const LocalizationResult r = localize_frame(l, *in.sequence, jump);
  ASSERT_EQ(r.state, LocalizationState::kRelocalized);
  const auto m = mapped_pose(fixture().mapped, r.timestamp);
  ASSERT_TRUE(m);
  EXPECT_LT((m->translation() - r.world_from_cam.translation()).norm(), 0.02);
  EXPECT_EQ(localize_frame(l, *in.sequence, jump + 1).state, LocalizationState::kTracking);
  EXPECT_EQ(l.stats().lost, 3u);
  EXPECT_EQ(l.stats().relocalizations, 2u);
}

// Where the map has nothing to match (here: its points erased after frame 9, as if the walk had
// left the mapped part), the localizer carries the pose on by odometry, reported as such, close
// to where SLAM had the frames; after its budget it reports lost, and the fusion-facing stats
// keep the two apart.
TEST(Localizer, BridgesByOdometryWhereTheMapHasNoPointsThenReportsLost) {
  Inputs in = open_inputs();
  LocalizerOptions options = options_from_settings(in.settings);
  options.odometry.max_frames = 20;
  Localizer l(*in.map, test_support::vocabulary(), in.settings, options);
  for (std::size_t i = 0; i < 10; ++i)
    ASSERT_NE(localize_frame(l, *in.sequence, i).state, LocalizationState::kLost) << "frame " << i;
  {
    std::lock_guard lock(in.map->shared.mutex);
    std::vector<MapPointId> ids;
    for (const auto& [id, point] : in.map->shared.map.points())
      ids.push_back(id);
    for (const MapPointId id : ids)
      in.map->shared.map.erase_point(id);
  }
  double worst = 0.0;
  for (std::size_t i = 10; i < 30; ++i) {
    const LocalizationResult r = localize_frame(l, *in.sequence, i);
    ASSERT_EQ(r.state, LocalizationState::kOdometry) << "frame " << i;
    EXPECT_GE(r.inliers, 30);
    EXPECT_EQ(r.reprojection_rms_px, 0.0);
    const auto m = mapped_pose(fixture().mapped, r.timestamp);
    ASSERT_TRUE(m);
    worst = std::max(worst, (m->translation() - r.world_from_cam.translation()).norm());
  }
  EXPECT_LT(worst, 0.02) << "metres from the mapped poses after 20 bridged frames";
  EXPECT_EQ(localize_frame(l, *in.sequence, 30).state, LocalizationState::kLost);
  const LocalizerStats& s = l.stats();
  EXPECT_EQ(s.localized, 10u);
  EXPECT_EQ(s.bridged, 20u);
  EXPECT_EQ(s.lost, 1u);
  EXPECT_STREQ(to_string(LocalizationState::kOdometry), "odometry");
}

// The walk's own depth fused with the mapped poses, moved by `shift` (map frame): a scan that
// agrees with the map except for that offset.
std::vector<Eigen::Vector3f> shifted_scan(const Inputs& in, const Eigen::Vector3d& shift) {
  const DepthSampler sampler(in.settings.camera, 4);
  std::vector<Eigen::Vector3f> cloud;
  for (std::size_t i = 0; i < in.sequence->size(); i += 10) {
    const dataset::Frame f = in.sequence->frame(i);
    const auto pose = mapped_pose(fixture().mapped, f.timestamp);
    if (!pose) continue;
    for (const Eigen::Vector3d& p : sampler.points(f.depth, 0.2, 5.0))
      cloud.push_back((*pose * p + shift).cast<float>());
  }
  return cloud;
}

// Anchored poses follow the scan, not the map: with the scan 3 cm off the map, every localized
// frame is anchored and lands 3 cm off its mapped pose; a scan 40 cm off (beyond what a
// registration leaves) is refused on every frame and the visual poses stay.
TEST(Localizer, AnchoredPosesFollowTheScanNotTheMap) {
  Inputs in = open_inputs();
  const Eigen::Vector3d shift(0.03, -0.02, 0.01);
  Localizer l = make_localizer(in);
  l.anchor_to_scan(std::make_shared<const ScanAnchor>(shifted_scan(in, shift)));
  std::vector<double> errors;
  for (std::size_t i = 0; i < in.sequence->size(); i += 2) {
    const LocalizationResult r = localize_frame(l, *in.sequence, i);
    ASSERT_NE(r.state, LocalizationState::kLost) << "frame " << i;
    ASSERT_TRUE(r.scan_anchored) << "frame " << i;
    EXPECT_GT(r.scan_inliers, 300);
    const auto m = mapped_pose(fixture().mapped, r.timestamp);
    ASSERT_TRUE(m);
    errors.push_back((r.world_from_cam.translation() - (m->translation() + shift)).norm());
  }
  std::sort(errors.begin(), errors.end());
  EXPECT_LT(errors[errors.size() / 2], 0.004) << "median metres from mapped pose + shift";
  EXPECT_LT(errors[errors.size() * 9 / 10], 0.008) << "90th percentile";
  EXPECT_EQ(l.stats().anchored, l.stats().frames);

  Localizer refused = make_localizer(in);
  refused.anchor_to_scan(
      std::make_shared<const ScanAnchor>(shifted_scan(in, Eigen::Vector3d(0.4, 0.0, 0.0))));
  for (std::size_t i = 0; i < 20; ++i) {
    const LocalizationResult r = localize_frame(refused, *in.sequence, i);
    EXPECT_FALSE(r.scan_anchored) << "frame " << i;
    const auto m = mapped_pose(fixture().mapped, r.timestamp);
    ASSERT_TRUE(m);
    EXPECT_LT((r.world_from_cam.translation() - m->translation()).norm(), 0.01) << "frame " << i;
  }
  EXPECT_EQ(refused.stats().anchored, 0u);
}

// The map is read only: after localizing (tracking, loss, relocalization, reset) it equals a
// second load of the same file field by field (points' visible/found counts included), and the
// file's bytes are unchanged.
TEST(Localizer, NeverChangesTheMap) {
  const std::uint64_t hash_before = file_hash(fixture().map);
  Inputs in = open_inputs();
  const auto reference = load_localization_map(fixture().map, test_support::vocabulary());
  const std::size_t keyframes = in.map->keyframes(), points = in.map->points();
  Localizer l = make_localizer(in);
  for (std::size_t i = 0; i < in.sequence->size(); i += 3)
    localize_frame(l, *in.sequence, i);
  l.reset();
  localize_frame(l, *in.sequence, 100);
  EXPECT_GE(l.stats().localized, 50u);
  EXPECT_EQ(in.map->keyframes(), keyframes);
  EXPECT_EQ(in.map->points(), points);
  EXPECT_EQ(mapdb::test::map_difference(in.map->shared.map, reference->shared.map), "");
  EXPECT_EQ(in.map->shared.database.size(), reference->shared.database.size());
  EXPECT_EQ(file_hash(fixture().map), hash_before);
}

// A map loaded for localization holds what tracking and relocalization read, nothing more: no
// keyframe depth images (registration and the viewer load those) and no keyframe BoW vectors
// (the database has their weights). Everything else equals a full load of the file, and cold
// starts relocalize through the database alone.
TEST(Localizer, MapHoldsOnlyWhatLocalizationReads) {
  Inputs in = open_inputs();
  const LocalizationMap& light = *in.map;
  for (const auto& [id, kf] : light.shared.map.keyframes()) {
    EXPECT_FALSE(kf.depth.has_value()) << "keyframe " << id.value();
    EXPECT_TRUE(kf.frame.bow.empty()) << "keyframe " << id.value();
    // Matching by BoW reads the feature vectors: they stay.
    EXPECT_FALSE(kf.frame.feature_vector.entries.empty()) << "keyframe " << id.value();
    // Nothing searches in a keyframe's image: no keypoint depth, no grid.
    EXPECT_TRUE(kf.frame.depth.empty() && kf.frame.u_right.empty()) << "keyframe " << id.value();
    EXPECT_TRUE(kf.frame.grid_starts().empty()) << "keyframe " << id.value();
    EXPECT_EQ(kf.frame.outlier.size(), kf.frame.size()) << "keyframe " << id.value();
  }
  mapdb::LoadedMap full = mapdb::load_map(fixture().map, test_support::vocabulary());
  std::size_t with_depth = 0;
  full.map.for_each_keyframe([&](map::Keyframe& kf) {
    with_depth += kf.depth.has_value() ? 1 : 0;
    EXPECT_FALSE(kf.frame.bow.empty()) << "keyframe " << kf.id.value();
    EXPECT_FALSE(kf.frame.grid_starts().empty()) << "keyframe " << kf.id.value();
    kf.depth.reset();
    kf.frame.bow = {};
    kf.frame.drop_search_data();
  });
  EXPECT_GT(with_depth, 0u);  // the file has depth images: the localizer left them there
  EXPECT_EQ(mapdb::test::map_difference(full.map, light.shared.map), "");
  EXPECT_EQ(light.shared.database.size(), full.database.size());

  for (std::size_t start : {20u, 95u, 170u}) {
    Localizer l = make_localizer(in);
    const LocalizationResult r = localize_frame(l, *in.sequence, start);
    ASSERT_EQ(r.state, LocalizationState::kRelocalized) << "frame " << start;
    const auto m = mapped_pose(fixture().mapped, r.timestamp);
    ASSERT_TRUE(m);
    EXPECT_LT((m->translation() - r.world_from_cam.translation()).norm(), 0.02);
  }
}

// Two localizers on one map in two threads (the map shared read-only): both localize.
TEST(Localizer, TwoLocalizersShareOneMap) {
  Inputs in = open_inputs();
  std::atomic<int> localized{0};
  auto run = [&](std::size_t first) {
    Localizer l = make_localizer(in);
    for (std::size_t i = first; i < first + 15; ++i)
      if (localize_frame(l, *in.sequence, i).state != LocalizationState::kLost) ++localized;
  };
  std::thread a(run, 10), b(run, 100);
  a.join();
  b.join();
  EXPECT_EQ(localized.load(), 30);
}

TEST(Localizer, RejectsFramesOfAnotherSize) {
  Inputs in = open_inputs();
  Localizer l = make_localizer(in);
  const cv::Mat small(240, 320, CV_8UC3, cv::Scalar(0));
  EXPECT_THROW(l.localize(small, cv::Mat(), 0.0), Error);
  EXPECT_THROW(l.localize(cv::Mat(), cv::Mat(), 0.0), Error);
}

TEST(Localizer, LoadingAMissingMapNamesTheFile) {
  try {
    load_localization_map("/nonexistent/site.db", test_support::vocabulary());
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/site.db"), std::string::npos) << e.what();
  }
}

// The C ABI (coloc_localize_c) on the same map, the settings taken from the map itself: a cold
// start mid-walk, then tracking, poses on the mapped trajectory.
// The fixture's map through the C ABI, with the shipped vocabulary and the settings in the map.
coloc_localizer* open_fixture_through_c_api(char* error, std::size_t size) {
  const std::string vocabulary =
      (test_support::source_dir() / "Vocabulary/coloc_orb_k10_L5.cvoc").string();
  return coloc_localizer_open(fixture().map.c_str(), vocabulary.c_str(), nullptr, error, size);
}

// One frame through the C ABI, from the frame's own memory.
int localize_through_c_api(coloc_localizer* h, const dataset::Frame& f, coloc_localize_pose& pose) {
  return coloc_localizer_localize(h, f.color.data, f.color.cols, f.color.rows, f.color.channels(),
                                  f.color.step, reinterpret_cast<const float*>(f.depth.data),
                                  f.depth.step, f.timestamp, &pose);
}

TEST(LocalizeCApi, LocalizesWithTheSettingsSavedInTheMap) {
  char error[512];
  coloc_localizer* h = open_fixture_through_c_api(error, sizeof error);
  ASSERT_NE(h, nullptr) << error;
  std::uint64_t keyframes = 0, points = 0;
  char frame[32];
  ASSERT_EQ(coloc_localizer_map_info(h, &keyframes, &points, frame, sizeof frame),
            COLOC_LOCALIZE_OK);
  EXPECT_GT(keyframes, 5u);
  EXPECT_GT(points, 1000u);
  EXPECT_STREQ(frame, "slam");
  const Inputs in = open_inputs();
  for (std::size_t i = 40; i < 50; ++i) {
    const dataset::Frame f = in.sequence->frame(i);
    coloc_localize_pose pose{};
    ASSERT_EQ(localize_through_c_api(h, f, pose), COLOC_LOCALIZE_OK)
        << coloc_localizer_last_error(h);
    EXPECT_EQ(pose.state, i == 40 ? COLOC_LOCALIZE_RELOCALIZED : COLOC_LOCALIZE_TRACKING);
    const auto m = mapped_pose(fixture().mapped, f.timestamp);
    ASSERT_TRUE(m);
    EXPECT_LT(
        (m->translation() - Eigen::Vector3d(pose.position[0], pose.position[1], pose.position[2]))
            .norm(),
        0.02);
    EXPECT_GT(pose.inliers, 100);
  }
  // Wrong size: an error with a message, the handle still usable.
  const std::vector<std::uint8_t> small(100 * 100, 0);
  coloc_localize_pose pose{};
  EXPECT_EQ(coloc_localizer_localize(h, small.data(), 100, 100, 1, 100, nullptr, 0, 1.0, &pose),
            COLOC_LOCALIZE_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(std::string(coloc_localizer_last_error(h)).find("Camera.width"), std::string::npos);
  EXPECT_EQ(coloc_localizer_reset(h), COLOC_LOCALIZE_OK);
  coloc_localizer_close(h);
}

// The anchor through the C ABI: the scan 3 cm off the map moves the poses by 3 cm; a NaN point
// is refused with its index named, and the handle goes on as before.
TEST(LocalizeCApi, AnchorsThePosesToAScan) {
  char error[512];
  coloc_localizer* h = open_fixture_through_c_api(error, sizeof error);
  ASSERT_NE(h, nullptr) << error;
  const Inputs in = open_inputs();
  const Eigen::Vector3d shift(0.03, -0.02, 0.01);
  std::vector<float> xyz;
  for (const Eigen::Vector3f& p : shifted_scan(in, shift))
    xyz.insert(xyz.end(), {p.x(), p.y(), p.z()});
  std::vector<float> bad = xyz;
  bad[4] = std::nanf("");
  EXPECT_EQ(coloc_localizer_anchor_to_scan(h, bad.data(), bad.size() / 3),
            COLOC_LOCALIZE_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(std::string(coloc_localizer_last_error(h)).find("point 1 "), std::string::npos);
  ASSERT_EQ(coloc_localizer_anchor_to_scan(h, xyz.data(), xyz.size() / 3), COLOC_LOCALIZE_OK)
      << coloc_localizer_last_error(h);
  for (std::size_t i = 40; i < 50; ++i) {
    const dataset::Frame f = in.sequence->frame(i);
    coloc_localize_pose pose{};
    ASSERT_EQ(localize_through_c_api(h, f, pose), COLOC_LOCALIZE_OK)
        << coloc_localizer_last_error(h);
    const auto m = mapped_pose(fixture().mapped, f.timestamp);
    ASSERT_TRUE(m);
    const Eigen::Vector3d c(pose.position[0], pose.position[1], pose.position[2]);
    EXPECT_LT((c - (m->translation() + shift)).norm(), 0.008) << "frame " << i;
  }
  EXPECT_EQ(coloc_localizer_anchor_to_scan(h, nullptr, 0), COLOC_LOCALIZE_OK);
  coloc_localizer_close(h);
}

}  // namespace
}  // namespace coloc::slam::localize
