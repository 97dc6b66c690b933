// The global BA with fixed scanned marker corners on the synthetic registration scene: the bend
// it removes, the displaced marker it rejects, and the relative weighting of its two terms.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "registration/align/marker_ba.hpp"
#include "registration/align/register.hpp"
#include "registration/align/synthetic.hpp"
#include "slam/core/error.hpp"
#include "slam/optim/bundle_adjustment.hpp"

namespace coloc::registration::align {
namespace {

SyntheticRegistrationOptions bent_scene() {
  SyntheticRegistrationOptions o;
  o.length = 14.0;
  o.pixel_noise = 0.3;
  o.depth_noise = 0.002;
  o.bend_deg_per_m = 0.25;  // ~3.5 degrees of heading drift over the walk
  o.slam_from_scan = SE3(SO3::exp(Eigen::Vector3d(0.0, 0.0, 0.6)), Eigen::Vector3d(-2, 1, 0));
  return o;
}

TEST(MarkerBa, RemovesAnInjectedBend) {
  SyntheticRegistration s = make_synthetic_registration(bent_scene());
  RegisterOptions o;
  o.level = Level::kRough;
  slam::map::Map rough_map = s.map;
  register_map(rough_map, s.scan_markers, s.camera, o);
  const double rough_error = keyframe_centre_rms(s, rough_map);
  EXPECT_GT(rough_error, 0.05);  // rigid alignment cannot undo a bend

  o.level = Level::kMarkers;
  const RegistrationResult r = register_map(s.map, s.scan_markers, s.camera, o);
  ASSERT_TRUE(r.ba);
  EXPECT_TRUE(r.ba->usable());
  EXPECT_TRUE(r.ba->rejected_ids().empty());
  const double error = keyframe_centre_rms(s, s.map);
  EXPECT_LT(error, 0.01) << "rough " << rough_error;
  EXPECT_LT(r.ba->final_marker_rms_px, 1.0);
  EXPECT_LT(r.ba->final_marker_rms_px, r.ba->initial_marker_rms_px);
  // The result's JSON (stored in the map's metadata) carries both levels' residuals.
  const auto j = nlohmann::json::parse(registration_json(r));
  EXPECT_EQ(j["level"], "markers");
  EXPECT_TRUE(j["rough"].contains("rms_m"));
  EXPECT_TRUE(j["markers"].contains("marker_rms_px"));
}

TEST(MarkerBa, RejectsAMarkerDisplacedBy20cmWithoutBendingTheMap) {
  const SyntheticRegistrationOptions so = bent_scene();
  SyntheticRegistration clean = make_synthetic_registration(so);
  SyntheticRegistration moved = make_synthetic_registration(so);
  for (auto& c : moved.scan_markers.markers.at(3).corners)
    c += Eigen::Vector3d(0.2, 0.0, 0.0);  // slid 20 cm along the wall after the scan
  const RegistrationResult rc = register_map(clean.map, clean.scan_markers, clean.camera);
  const RegistrationResult rm = register_map(moved.map, moved.scan_markers, moved.camera);
  ASSERT_TRUE(rm.ba);
  EXPECT_EQ(rm.ba->rejected_ids(), std::vector<int>{3});
  EXPECT_LT(keyframe_centre_rms(moved, moved.map), 0.01);
  // Not bent: each keyframe within a few millimetres of where the clean run put it.
  double worst = 0.0;
  for (const auto& [id, kf] : moved.map.keyframes()) {
    worst = std::max(worst, (kf.camera_centre() - clean.map.keyframe(id)->camera_centre()).norm());
  }
  EXPECT_LT(worst, 0.01);
  for (const MarkerBaMarker& m : rm.ba->markers) {
    if (m.id == 3) {
      EXPECT_GT(m.final_rms_px, 20.0);  // ~40 px at 2.5 m: reported, not absorbed
    }
  }
  (void)rc;
}

// Paper: "the weight of the marker pose error is equally contributing": with the defaults a
// marker corner's whitened residual is that of a level-0 keypoint (sigma 1 px) at the same place.
TEST(MarkerBa, MarkerCornerWeighsAsALevelZeroKeypoint) {
  const slam::optim::Intrinsics k{525.0, 525.0, 319.5, 239.5, 40.0};
  const SE3 pose(SO3::exp(Eigen::Vector3d(0.1, -0.2, 0.05)), Eigen::Vector3d(0.3, -0.1, 0.2));
  const Eigen::Vector3d corner(0.4, -0.3, 3.0);
  const Eigen::Vector2d pixel(400.0, 180.0);
  double x[7];
  slam::optim::pose_to_array(pose, x);
  const MarkerBaOptions o;
  const MarkerCornerCost marker(k, pixel, corner, std::sqrt(o.marker_weight) / o.marker_sigma_px);
  const slam::optim::MonoReprojectionCost keypoint(k, pixel, 1.0);  // level 0: inv_sigma2 = 1
  double rm[2], rk[2];
  const double* pm[] = {x};
  const double* pk[] = {x, corner.data()};
  ASSERT_TRUE(marker.Evaluate(pm, rm, nullptr));
  ASSERT_TRUE(keypoint.Evaluate(pk, rk, nullptr));
  EXPECT_DOUBLE_EQ(rm[0], rk[0]);
  EXPECT_DOUBLE_EQ(rm[1], rk[1]);
  // marker_weight w scales the information: the whitened residual by sqrt(w).
  const MarkerCornerCost heavy(k, pixel, corner, std::sqrt(4.0) / o.marker_sigma_px);
  double rh[2];
  ASSERT_TRUE(heavy.Evaluate(pm, rh, nullptr));
  EXPECT_DOUBLE_EQ(rh[0], 2.0 * rm[0]);
}

TEST(MarkerBa, MarkerCornerJacobianMatchesNumeric) {
  const slam::optim::Intrinsics k{500.0, 510.0, 320.0, 240.0, 40.0};
  const SE3 pose(SO3::exp(Eigen::Vector3d(0.2, 0.1, -0.3)), Eigen::Vector3d(0.1, 0.2, 0.5));
  const MarkerCornerCost cost(k, {300.0, 200.0}, {0.2, -0.4, 2.5}, 0.7);
  double x[7];
  slam::optim::pose_to_array(pose, x);
  double r[2], jac[14];
  const double* params[] = {x};
  double* jacs[] = {jac};
  ASSERT_TRUE(cost.Evaluate(params, r, jacs));
  const slam::optim::PoseManifold manifold;
  const double h = 1e-6;
  for (int d = 0; d < 6; ++d) {
    double delta[6] = {0, 0, 0, 0, 0, 0}, xp[7], xm[7], rp[2], rmm[2];
    delta[d] = h;
    manifold.Plus(x, delta, xp);
    delta[d] = -h;
    manifold.Plus(x, delta, xm);
    const double* pp[] = {xp};
    const double* pm[] = {xm};
    cost.Evaluate(pp, rp, nullptr);
    cost.Evaluate(pm, rmm, nullptr);
    for (int row = 0; row < 2; ++row)
      EXPECT_NEAR(jac[row * 7 + d], (rp[row] - rmm[row]) / (2 * h), 1e-5) << row << "," << d;
  }
}

TEST(MarkerBa, HeavierMarkersPullHarder) {
  // With too few markers to straighten the map, the weight decides the compromise: more weight,
  // smaller marker residuals, larger map-point residuals.
  SyntheticRegistrationOptions so = bent_scene();
  so.marker_spacing = 6.0;
  auto run = [&](double weight) {
    SyntheticRegistration s = make_synthetic_registration(so);
    RegisterOptions o;
    o.rough.min_markers = 2;
    o.ba.marker_weight = weight;
    o.ba.marker_gate_px = 1e3;  // keep every marker: this is about weighting
    return *register_map(s.map, s.scan_markers, s.camera, o).ba;
  };
  const MarkerBaReport light = run(0.01), heavy = run(100.0);
  EXPECT_LT(heavy.final_marker_rms_px, light.final_marker_rms_px);
  EXPECT_GE(heavy.final_point_rms_px, light.final_point_rms_px);
}

TEST(MarkerBa, OptionsAndInputsGiveNamedErrors) {
  MarkerBaOptions o;
  o.marker_sigma_px = 0.0;
  try {
    o.check();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "marker_sigma_px");
  }
  slam::map::Map empty;
  try {
    marker_bundle_adjustment(empty, {}, PinholeCamera{});
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "keyframes");
  }
  EXPECT_THROW(parse_level("pointcloudx"), Error);
}

}  // namespace
}  // namespace coloc::registration::align
