// Composition: per-registration M_c2v, chordal mean, T_A2B, locked-controller stability.

#include <gtest/gtest.h>

#include "registration/handeye/compose.hpp"
#include "registration/handeye/simulate.hpp"
#include "slam/core/error.hpp"

namespace coloc::registration::handeye {
namespace {

TEST(HandeyeCompose, ChordalMeanOfSymmetricSpreadIsCentre) {
  const SE3 centre(SO3::exp(Eigen::Vector3d(0.4, -0.2, 1.0)), Eigen::Vector3d(1, 2, 3));
  std::vector<SE3> poses;
  for (int axis = 0; axis < 3; ++axis) {
    for (double sign : {-1.0, 1.0}) {
      Eigen::Vector3d w = Eigen::Vector3d::Zero();
      w(axis) = 0.1 * sign;
      Eigen::Vector3d t = Eigen::Vector3d::Zero();
      t(axis) = 0.01 * sign;
      poses.push_back(SE3(centre.so3() * SO3::exp(w), centre.translation() + t));
    }
  }
  const SE3 mean = chordal_mean(poses);
  EXPECT_LT(angular_distance(mean.so3(), centre.so3()), 1e-12);
  EXPECT_LT((mean.translation() - centre.translation()).norm(), 1e-12);
  const Dispersion d = dispersion(poses);
  EXPECT_NEAR(d.rotation_mean_abs, 0.1, 1e-12);
  EXPECT_NEAR(d.rotation_rms, 0.1, 1e-12);
  EXPECT_NEAR(d.translation_max, 0.01, 1e-12);
  EXPECT_TRUE(chordal_mean({}).translation().isZero());
}

// Two VR systems seeing controllers locked together through the same camera.
TEST(HandeyeCompose, LinkAndLockedStability) {
  SimulationOptions o;
  o.seed = 4;
  o.device_rotation_noise = o.device_translation_noise = 0;
  o.marker_rotation_noise = o.marker_translation_noise = 0;
  const Simulation a = simulate(o);
  o.seed = 5;
  const Simulation b = simulate(o);  // another VR origin (same camera placement model)
  // vr_b_from_vr_a maps A's space to B's: a point fixed in the room agrees in both.
  const SE3 b_from_a = vr_b_from_vr_a(a.vr_from_camera, b.vr_from_camera);
  const SE3 expected = b.world_from_vr.inverse() * a.world_from_vr;
  EXPECT_LT(rotation_distance(b_from_a, expected), 1e-12);
  EXPECT_LT(translation_distance(b_from_a, expected), 1e-12);

  // Controller B is locked to controller A at device_a_from_device_b.
  const SE3 device_a_from_device_b(SO3::exp(Eigen::Vector3d(0.1, 0.2, 0.3)),
                                   Eigen::Vector3d(0.1, 0, 0));
  std::vector<SE3> vr_a_from_device_a, vr_b_from_device_b;
  for (const SE3& world_from_device_a : a.world_from_device) {
    vr_a_from_device_a.push_back(a.world_from_vr.inverse() * world_from_device_a);
    vr_b_from_device_b.push_back(b.world_from_vr.inverse() * world_from_device_a *
                                 device_a_from_device_b);
  }
  const Dispersion s = locked_controller_stability(vr_a_from_device_a, vr_b_from_device_b,
                                                   a.vr_from_camera, b.vr_from_camera);
  EXPECT_LT(s.rotation_max, 1e-12);
  EXPECT_LT(s.translation_max, 1e-12);
  // The constant is device_b_from_device_a.
  EXPECT_LT(rotation_distance(s.mean, device_a_from_device_b.inverse()), 1e-12);
  EXPECT_THROW(
      locked_controller_stability(vr_a_from_device_a, {}, a.vr_from_camera, b.vr_from_camera),
      Error);
}

}  // namespace
}  // namespace coloc::registration::handeye
