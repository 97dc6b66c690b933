// The global BA against the scan's surface on the synthetic registration scene: the bend a rigid
// registration leaves is removed without markers, markers and surface work together, the
// point-to-plane terms' Jacobians, and named errors.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "registration/align/markerless.hpp"
#include "registration/align/register.hpp"
#include "registration/align/scan_surface.hpp"
#include "registration/align/surface_ba.hpp"
#include "registration/align/synthetic.hpp"
#include "slam/core/error.hpp"
#include "slam/optim/bundle_adjustment.hpp"

namespace coloc::registration::align {
namespace {

SyntheticRegistrationOptions bent_scene() {
  SyntheticRegistrationOptions o;
  o.length = 10.0;
  o.points_per_m2 = 12.0;
  o.pixel_noise = 0.3;
  o.depth_noise = 0.002;
  o.bend_deg_per_m = 0.3;  // 3 degrees of heading drift over the walk
  o.slam_from_scan = SE3(SO3::exp(Eigen::Vector3d(0.0, 0.0, 0.6)), Eigen::Vector3d(-2, 1, 0));
  return o;
}

// The scene's map moved into the scan's frame by a rigid fit (the markers' rough alignment: the
// bend stays, as after the markerless rigid registration).
struct RigidScene {
  SyntheticRegistration scene = make_synthetic_registration(bent_scene());
  render::PointCloud scan = synthetic_scan_surface(scene);
  RigidScene() {
    RegisterOptions o;
    o.level = Level::kRough;
    register_map(scene.map, scene.scan_markers, scene.camera, o);
  }
};

TEST(SurfaceBa, RemovesTheBendARigidRegistrationLeaves) {
  RigidScene s;
  const double rigid_error = keyframe_centre_rms(s.scene, s.scene.map);
  EXPECT_GT(rigid_error, 0.05);
  const ScanSurface surface(s.scan);
  const SurfaceBaReport r = surface_bundle_adjustment(s.scene.map, surface, s.scene.camera,
                                                      synthetic_depth_samples(s.scene, s.scan));
  const double error = keyframe_centre_rms(s.scene, s.scene.map);
  EXPECT_LT(error, 0.005) << "rigid " << rigid_error;  // 16 cm -> 1.9 mm
  ASSERT_EQ(r.rounds.size(), SurfaceBaOptions{}.gates_m.size());
  EXPECT_LT(r.rounds.back().median_after_m, 0.005);
  EXPECT_LT(r.rounds.back().median_after_m, r.rounds.front().median_before_m);
  EXPECT_GT(r.depth_samples, 0u);
  EXPECT_LT(r.final_point_rms_px, 1.0);
}

TEST(SurfaceBa, MapPointsAloneStillPullTheMapOntoTheScan) {
  RigidScene s;
  const double rigid_error = keyframe_centre_rms(s.scene, s.scene.map);
  const ScanSurface surface(s.scan);
  surface_bundle_adjustment(s.scene.map, surface, s.scene.camera, {});
  EXPECT_LT(keyframe_centre_rms(s.scene, s.scene.map), 0.01) << "rigid " << rigid_error;
}

TEST(SurfaceBa, MarkersAndSurfaceTogether) {
  RigidScene s;
  ScanCorners corners;
  for (const auto& [id, m] : s.scene.scan_markers.markers)
    corners.emplace(id, m.corners);
  const ScanSurface surface(s.scan);
  SurfaceBaMarkers markers;
  markers.corners = &corners;
  const SurfaceBaReport r = surface_bundle_adjustment(
      s.scene.map, surface, s.scene.camera, synthetic_depth_samples(s.scene, s.scan), {}, markers);
  EXPECT_GT(r.marker_observations, 0u);
  EXPECT_LT(keyframe_centre_rms(s.scene, s.scene.map), 0.005);
}

TEST(SurfaceBa, LevelSurfaceRegistersByMarkersThenBendsOntoTheSurface) {
  SyntheticRegistration scene = make_synthetic_registration(bent_scene());
  const render::PointCloud scan = synthetic_scan_surface(scene);
  const KeyframeDepthSamples depth = synthetic_depth_samples(scene, scan);
  RegisterOptions o;
  o.level = Level::kSurface;
  EXPECT_THROW(register_map(scene.map, scene.scan_markers, scene.camera, o), Error);
  const RegistrationResult r =
      register_map(scene.map, scene.scan_markers, scene.camera, o, &scan, {}, &depth);
  ASSERT_TRUE(r.ba && r.surface);
  EXPECT_GT(r.surface->marker_observations, 0u);
  EXPECT_LT(keyframe_centre_rms(scene, scene.map), 0.005);
  const auto j = nlohmann::json::parse(registration_json(r));
  EXPECT_EQ(j["level"], "surface");
  EXPECT_EQ(j["surface"]["rounds"].size(), SurfaceBaOptions{}.gates_m.size());
}

// Numeric Jacobian of a one-row cost on a pose block, through the pose manifold.
template <class Cost>
void expect_pose_jacobian(const Cost& cost, const SE3& pose) {
  double x[7];
  slam::optim::pose_to_array(pose, x);
  double r = 0.0, jac[7];
  const double* params[] = {x};
  double* jacs[] = {jac};
  ASSERT_TRUE(cost.Evaluate(params, &r, jacs));
  const slam::optim::PoseManifold manifold;
  const double h = 1e-6;
  for (int d = 0; d < 6; ++d) {
    double delta[6] = {0, 0, 0, 0, 0, 0}, xp[7], xm[7], rp = 0.0, rm = 0.0;
    delta[d] = h;
    manifold.Plus(x, delta, xp);
    delta[d] = -h;
    manifold.Plus(x, delta, xm);
    const double* pp[] = {xp};
    const double* pm[] = {xm};
    cost.Evaluate(pp, &rp, nullptr);
    cost.Evaluate(pm, &rm, nullptr);
    EXPECT_NEAR(jac[d], (rp - rm) / (2 * h), 1e-5) << d;
  }
  EXPECT_EQ(jac[6], 0.0);
}

TEST(SurfaceBa, DepthToPlaneJacobianMatchesNumeric) {
  const Eigen::Vector3d n = Eigen::Vector3d(0.3, -0.5, 0.8).normalized();
  const DepthToPlaneCost cost({0.2, -0.1, 2.4}, {1.0, 2.0, 0.5}, n, 40.0);
  expect_pose_jacobian(
      cost, SE3(SO3::exp(Eigen::Vector3d(0.2, 0.1, -0.3)), Eigen::Vector3d(0.1, 0.2, 0.5)));
}

TEST(SurfaceBa, PointToPlaneIsTheSignedDistanceOverSigma) {
  const Eigen::Vector3d n = Eigen::Vector3d(0.0, 0.6, 0.8);
  const PointToPlaneCost cost({1.0, 1.0, 1.0}, n, 50.0);
  const double x[3] = {1.5, 1.1, 1.2};  // 0.06 + 0.16 = 0.22 m along n
  const double* params[] = {x};
  double r = 0.0, jac[3];
  double* jacs[] = {jac};
  ASSERT_TRUE(cost.Evaluate(params, &r, jacs));
  EXPECT_NEAR(r, 50.0 * 0.22, 1e-12);
  EXPECT_NEAR(jac[0], 0.0, 1e-12);
  EXPECT_NEAR(jac[1], 30.0, 1e-12);
  EXPECT_NEAR(jac[2], 40.0, 1e-12);
}

TEST(SurfaceBa, TheSurfaceAnswersWithNormalsWithinTheGate) {
  render::PointCloud floor;
  for (int i = 0; i < 100; ++i) {
    for (int j = 0; j < 100; ++j) {
      floor.points.emplace_back(0.01f * i, 0.01f * j, 0.0f);
      floor.colours.push_back({0, 0, 0});
    }
  }
  const ScanSurface surface(floor);
  const auto hit = surface.nearest({0.5, 0.5, 0.03}, 0.05);
  ASSERT_TRUE(hit);
  EXPECT_NEAR(std::abs(hit->normal.z()), 1.0, 1e-3);
  EXPECT_NEAR(hit->normal.dot(Eigen::Vector3d(0.5, 0.5, 0.03) - hit->point), 0.03, 2e-3);
  EXPECT_FALSE(surface.nearest({0.5, 0.5, 0.2}, 0.05));
  EXPECT_FALSE(surface.nearest({NAN, 0.5, 0.0}, 0.05));
}

// Gives every keyframe of `map` an accelerometer window: gravity's reaction `up_slam` (unit,
// map frame) times 9.81 seen in the camera, plus the camera's own acceleration `accel_world`.
void add_gravity_windows(slam::map::Map& map, const Eigen::Vector3d& up_slam,
                         const Eigen::Vector3d& accel_world) {
  std::vector<KeyframeId> ids;
  for (const auto& [id, kf] : map.keyframes())
    ids.push_back(id);
  for (KeyframeId id : ids) {
    slam::map::Keyframe* kf = map.keyframe(id);
    slam::map::GravityWindow g;
    g.recording = ids.front();
    g.specific_force_cam = kf->cam_from_world().so3() * (9.81 * up_slam + accel_world);
    g.accel_world = accel_world;
    kf->gravity = g;
  }
}

TEST(MapGravity, TheUpDirectionComesFromTheKeyframesAccelerometerWindows) {
  SyntheticRegistrationOptions o = bent_scene();
  o.slam_from_scan = SE3(SO3::exp(Eigen::Vector3d(0.3, -0.2, 0.6)), Eigen::Vector3d(1, 2, 3));
  SyntheticRegistration s = make_synthetic_registration(o);
  const Eigen::Vector3d up = o.slam_from_scan.so3() * Eigen::Vector3d::UnitZ();
  add_gravity_windows(s.map, up, Eigen::Vector3d(0.3, -0.1, 0.2));
  std::size_t windows = 0;
  const auto found = map_up_direction(s.map, 5, &windows);
  ASSERT_TRUE(found);
  EXPECT_EQ(windows, s.map.keyframe_count());
  EXPECT_LT(std::acos(std::min(1.0, found->dot(up))), 1e-6);
  // Too few windows, or windows that disagree: no direction rather than a wrong one.
  EXPECT_FALSE(map_up_direction(s.map, s.map.keyframe_count() + 1));
  std::size_t k = 0;
  for (const auto& [id, kf] : s.map.keyframes()) {
    if (k++ % 2 == 0) s.map.keyframe(id)->gravity->specific_force_cam *= -1.0;
  }
  EXPECT_FALSE(map_up_direction(s.map));
}

TEST(SurfaceBa, OptionsAndInputsGiveNamedErrors) {
  const auto field_of = [](auto&& f) {
    try {
      f();
    } catch (const Error& e) {
      return e.context().field;
    }
    return std::string("no error");
  };
  SurfaceBaOptions o;
  o.gates_m = {};
  EXPECT_EQ(field_of([&] { o.check(); }), "gates_m");
  o = {};
  o.gates_m = {0.1, -0.02};
  EXPECT_EQ(field_of([&] { o.check(); }), "gates_m");
  o = {};
  o.depth_sigma_m = 0.0;
  EXPECT_EQ(field_of([&] { o.check(); }), "depth_sigma_m");
  ScanSurfaceOptions so;
  so.normal_radius = so.voxel_size;
  EXPECT_EQ(field_of([&] { so.check(); }), "normal_radius");
  EXPECT_EQ(field_of([] { ScanSurface surface(render::PointCloud{}); }), "scan");

  RigidScene s;
  const ScanSurface surface(s.scan);
  slam::map::Map one;
  EXPECT_EQ(field_of([&] { surface_bundle_adjustment(one, surface, s.scene.camera, {}); }),
            "keyframes");
}

}  // namespace
}  // namespace coloc::registration::align
