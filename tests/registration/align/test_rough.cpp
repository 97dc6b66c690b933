// Marker corners in the SLAM frame and rough alignment on the synthetic registration scene.
#include <gtest/gtest.h>

#include "registration/align/rough.hpp"
#include "registration/align/slam_markers.hpp"
#include "registration/align/synthetic.hpp"
#include "registration/align/transform.hpp"
#include "slam/core/error.hpp"

namespace coloc::registration::align {
namespace {

SyntheticRegistrationOptions offset_scene() {
  SyntheticRegistrationOptions o;
  o.length = 10.0;
  o.slam_from_scan = SE3(SO3::exp(Eigen::Vector3d(0.05, -0.1, 0.8)), Eigen::Vector3d(-3, 1, 0.5));
  return o;
}

TEST(SlamMarkers, ExactCornersFromExactObservations) {
  const SyntheticRegistrationOptions o = offset_scene();
  const SyntheticRegistration s = make_synthetic_registration(o);
  const SlamMarkers m = slam_marker_corners(s.map, s.camera);
  ASSERT_EQ(m.markers.size(), s.scan_markers.markers.size());
  for (const auto& [id, marker] : m.markers) {
    EXPECT_TRUE(marker.triangulated) << id;
    EXPECT_GE(marker.keyframes.size(), 2u);
    for (int c = 0; c < 4; ++c) {
      const Eigen::Vector3d truth = drift_point(o, s.scan_markers.markers.at(id).corners[c]);
      EXPECT_LT((marker.corners[c] - truth).norm(), 1e-6) << "marker " << id << " corner " << c;
    }
  }
}

TEST(RoughAlignment, ExactOnExactData) {
  const SyntheticRegistrationOptions o = offset_scene();
  SyntheticRegistration s = make_synthetic_registration(o);
  const RoughAlignment r = rough_align(slam_marker_corners(s.map, s.camera), s.scan_markers);
  EXPECT_EQ(r.inliers, s.scan_markers.markers.size());
  EXPECT_LT(r.rms, 1e-6);
  const SE3 expected = o.slam_from_scan.inverse();
  EXPECT_LT((r.scan_from_slam.translation() - expected.translation()).norm(), 1e-6);
  EXPECT_LT((r.scan_from_slam.so3().inverse() * expected.so3()).log().norm(), 1e-8);
  EXPECT_DOUBLE_EQ(r.scan_from_slam.scale(), 1.0);
  for (const MarkerResidual& m : r.markers) {
    EXPECT_TRUE(m.inlier);
    EXPECT_LT(m.residual, 1e-6);
  }
  // Moving the map by the result puts every keyframe where it truly is.
  transform_map(s.map, r.scan_from_slam);
  EXPECT_LT(keyframe_centre_rms(s, s.map), 1e-6);
}

TEST(RoughAlignment, SimilarityRecoversScale) {
  SyntheticRegistration s = make_synthetic_registration(offset_scene());
  const Sim3 scaled(1.3, SO3::exp(Eigen::Vector3d(0, 0, 0.4)), Eigen::Vector3d(1, 2, 3));
  transform_map(s.map, scaled);
  for (const auto& [id, kf] : s.map.keyframes())
    s.map.keyframe(id)->marker_size *= 1.3;  // the map's unit is not the metre
  RoughOptions o;
  o.estimate_scale = true;
  o.inlier_threshold = 0.5;
  const RoughAlignment r = rough_align(slam_marker_corners(s.map, s.camera), s.scan_markers, o);
  EXPECT_NEAR(r.scan_from_slam.scale(), 1.0 / 1.3, 1e-6);
  transform_map(s.map, r.scan_from_slam);
  EXPECT_LT(keyframe_centre_rms(s, s.map), 1e-5);
}

TEST(RoughAlignment, RejectsADisplacedMarker) {
  SyntheticRegistrationOptions o = offset_scene();
  o.pixel_noise = 0.3;
  SyntheticRegistration s = make_synthetic_registration(o);
  for (auto& c : s.scan_markers.markers.at(2).corners)
    c += Eigen::Vector3d(0.0, 0.0, 0.5);  // moved 50 cm up the wall after the scan
  RoughOptions ro;
  ro.inlier_threshold = 0.2;
  const RoughAlignment r = rough_align(slam_marker_corners(s.map, s.camera), s.scan_markers, ro);
  EXPECT_EQ(r.inliers, s.scan_markers.markers.size() - 1);
  for (const MarkerResidual& m : r.markers) {
    EXPECT_EQ(m.inlier, m.id != 2) << m.id;
    if (m.id == 2) {
      EXPECT_NEAR(m.residual, 0.5, 0.05);
    }
  }
  transform_map(s.map, r.scan_from_slam);
  EXPECT_LT(keyframe_centre_rms(s, s.map), 0.02);
}

TEST(RoughAlignment, TooFewMarkersNamesWhereTheyWereSeen) {
  SyntheticRegistration s = make_synthetic_registration(offset_scene());
  markers::MarkerMap scan = s.scan_markers;
  for (int id = 2; id < 10; ++id)
    scan.markers.erase(id);  // the scan only has markers 0 and 1
  try {
    rough_align(slam_marker_corners(s.map, s.camera), scan);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "markers");
    const std::string what = e.what();
    EXPECT_NE(what.find("2 marker(s) common"), std::string::npos) << what;
    EXPECT_NE(what.find("id 3 in keyframes"), std::string::npos) << what;
    EXPECT_NE(what.find("In the scan: ids 0, 1"), std::string::npos) << what;
  }
}

TEST(RoughAlignment, InconsistentMarkersAreAnError) {
  SyntheticRegistration s = make_synthetic_registration(offset_scene());
  // Every marker moved its own way (e.g. the marker map of another site): no rigid transform
  // brings three of them together.
  markers::MarkerMap scan = s.scan_markers;
  const Eigen::Vector3d moves[] = {{0, 0, 0},  {3, 1, 0}, {-2, 2, 1},   {1, -3, 2}, {0, 2, -3},
                                   {-3, 0, 2}, {2, 2, 2}, {-1, -2, -2}, {3, -1, 1}, {1, 3, -1}};
  for (auto& [id, m] : scan.markers) {
    for (auto& c : m.corners)
      c += moves[static_cast<std::size_t>(id) % 10];
  }
  try {
    rough_align(slam_marker_corners(s.map, s.camera), scan);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "markers");
    EXPECT_NE(std::string(e.what()).find("inconsistent"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("Residual per marker"), std::string::npos) << e.what();
  }
}

TEST(RoughAlignment, NoMarkersInTheMap) {
  SyntheticRegistration s = make_synthetic_registration(offset_scene());
  for (const auto& [id, kf] : s.map.keyframes())
    s.map.keyframe(id)->markers.clear();
  try {
    rough_align(slam_marker_corners(s.map, s.camera), s.scan_markers);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no marker seen in any keyframe"), std::string::npos);
  }
}

TEST(RoughAlignment, OptionsNameTheBadField) {
  RoughOptions o;
  o.min_markers = 1;
  try {
    o.check();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "min_markers");
  }
  SlamMarkerOptions m;
  m.max_reprojection_px = 0.0;
  EXPECT_THROW(m.check(), Error);
}

}  // namespace
}  // namespace coloc::registration::align
