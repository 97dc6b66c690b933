// Real data: ViSP's Franka eye-to-hand recording (fixed camera, AprilTag on the end-effector).
// There is no true X; we judge by consistency: the per-registration base_from_camera
// (vr_from_camera here) should agree, and ours should agree at least as well as OpenCV's.

#include <gtest/gtest.h>

#include <cstdio>

#include "registration/handeye/compose.hpp"
#include "registration/handeye/opencv/compare.hpp"
#include "registration/handeye/opencv/visp_franka.hpp"
#include "tests/testing/data.hpp"

namespace coloc::registration::handeye {
namespace {

TEST(HandeyeVispFranka, ConsistentEyeToHand) {
  COLOC_REQUIRE_DATA(dir, "handeye_visp_franka/eye-to-hand");
  const FrankaSession session = load_visp_franka_eye_to_hand(dir);
  EXPECT_EQ(session.num_images, 8);
  ASSERT_EQ(session.registrations.size(), 8u);
  EXPECT_DOUBLE_EQ(session.tag_size, 0.048);
  for (double rms : session.reprojection_rms_px)
    EXPECT_LT(rms, 1.0);

  const Summary s = solve(session.registrations);
  ASSERT_TRUE(s.is_solution_usable()) << s.message;
  EXPECT_EQ(s.num_used, 8);
  const Dispersion ours =
      dispersion(vr_from_camera_per_registration(session.registrations, s.device_from_marker));
  std::printf(
      "ours: X = device_from_marker t = [%.4f %.4f %.4f] m, |t| %.1f mm; spread of "
      "base_from_camera: rot mean %.3f rms %.3f max %.3f deg, trans mean %.2f rms %.2f max "
      "%.2f mm; residual rms %.3f deg %.2f mm; std(X) %.3f deg %.2f mm\n",
      s.device_from_marker.translation().x(), s.device_from_marker.translation().y(),
      s.device_from_marker.translation().z(), s.device_from_marker.translation().norm() * 1e3,
      ours.rotation_mean_abs * 57.29578, ours.rotation_rms * 57.29578, ours.rotation_max * 57.29578,
      ours.translation_mean_abs * 1e3, ours.translation_rms * 1e3, ours.translation_max * 1e3,
      s.residuals.rotation_rms * 57.29578, s.residuals.translation_rms * 1e3,
      s.rotation_stddev * 57.29578, s.translation_stddev * 1e3);
  // A 48 mm tag at 0.14-0.26 m: the tag position agrees to ~2 mm; its rotation is the weak part
  // (registrations 1 and 2 disagree by 3 and 5 degrees, a near-frontal tag's PnP ambiguity), and
  // the camera placement inherits that through the 0.2 m lever arm.
  EXPECT_LT(s.residuals.translation_rms, 0.003);
  EXPECT_LT(s.residuals.rotation_rms, 0.05);
  EXPECT_LT(ours.translation_rms, 0.012);
  EXPECT_LT(ours.rotation_rms, 0.05);

  // Robust mode singles out the two registrations with the largest rotation disagreement.
  Options robust;
  robust.robust = true;
  const Summary r = solve(session.registrations, robust);
  ASSERT_TRUE(r.is_solution_usable()) << r.message;
  std::vector<bool> inliers = r.used;
  EXPECT_FALSE(inliers[1]);
  EXPECT_GE(r.num_used, 6);
  std::vector<Registration> kept;
  for (std::size_t k = 0; k < inliers.size(); ++k) {
    if (inliers[k]) kept.push_back(session.registrations[k]);
  }
  const Dispersion robust_spread =
      dispersion(vr_from_camera_per_registration(kept, r.device_from_marker));
  std::printf(
      "robust (%d of 8): spread rot rms %.3f deg, trans rms %.2f mm; residual rms %.3f deg "
      "%.2f mm\n",
      r.num_used, robust_spread.rotation_rms * 57.29578, robust_spread.translation_rms * 1e3,
      r.residuals.rotation_rms * 57.29578, r.residuals.translation_rms * 1e3);
  EXPECT_LT(robust_spread.rotation_rms, ours.rotation_rms);
  for (const OpencvMethod& m : opencv_methods()) {
    const SE3 x = opencv_hand_eye(session.registrations, m.method);
    const Dispersion theirs = dispersion(vr_from_camera_per_registration(session.registrations, x));
    std::printf("%-18s spread rot rms %.3f deg, trans rms %.2f mm; |X - ours| %.2f mm %.3f deg\n",
                m.name, theirs.rotation_rms * 57.29578, theirs.translation_rms * 1e3,
                translation_distance(x, s.device_from_marker) * 1e3,
                rotation_distance(x, s.device_from_marker) * 57.29578);
    // Same data, same consistency: ours is no worse than OpenCV's (within 5 %).
    EXPECT_LT(ours.translation_rms, 1.05 * theirs.translation_rms) << m.name;
  }
}

}  // namespace
}  // namespace coloc::registration::handeye
