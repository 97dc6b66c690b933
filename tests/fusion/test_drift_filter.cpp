#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "fusion/drift_filter.hpp"
#include "slam/core/error.hpp"

namespace coloc::fusion {
namespace {

SE3 make_pose(double yaw, const Eigen::Vector3d& t) {
  return SE3(SO3::from_axis_angle(Eigen::Vector3d::UnitZ(), yaw), t);
}

TEST(DriftFilter, MeasureDriftRecoversTheOffset) {
  const SE3 world_from_xr = make_pose(0.3, {1.0, -2.0, 0.5});
  const SE3 xr_from_head = make_pose(-1.1, {0.2, 0.4, 1.7});
  const SE3 d = measure_drift(world_from_xr * xr_from_head, xr_from_head);
  EXPECT_LT(translation_distance(d, world_from_xr), 1e-12);
  EXPECT_LT(rotation_distance(d, world_from_xr), 1e-12);
}

TEST(DriftFilter, ConvergesToConstantDrift) {
  const DriftFilterOptions options;  // the paper's Q = 0.001, R = 0.9
  const SE3 truth = make_pose(0.2, {0.3, -0.1, 0.05});
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.01);
  DriftEstimate e;
  for (int i = 0; i < 400; ++i) {
    const SE3 measured(SO3::exp(Eigen::Vector3d(noise(rng), noise(rng), noise(rng))) * truth.so3(),
                       truth.translation() + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
    const DriftUpdate u = update_drift(e, measured, options);
    EXPECT_NE(u.decision, GateDecision::kRejected) << i;
    e = u.estimate;
  }
  EXPECT_LT(translation_distance(e.drift(), truth), 0.005);
  EXPECT_LT(rotation_distance(e.drift(), truth), 0.005);
  EXPECT_NEAR(e.rotation.norm(), 1.0, 1e-12);
}

TEST(DriftFilter, SteadyStateGainMatchesIteratedFilter) {
  const DriftFilterOptions options;
  DriftEstimate e = initialize_drift(SE3(), options);
  double gain = 0.0;
  for (int i = 0; i < 2000; ++i) {
    const DriftEstimate p = predict_drift(e, options);
    gain = p.translation_variance / (p.translation_variance + options.measurement_noise);
    e = correct_drift(p, SE3(), options);
  }
  EXPECT_NEAR(gain, steady_state_gain(options.process_noise, options.measurement_noise), 1e-9);
  EXPECT_NEAR(gain, 0.0328, 1e-3);  // ~ sqrt(Q/R): about 30 global poses of memory
}

TEST(DriftFilter, QuaternionSignFlipCausesNoJump) {
  const DriftFilterOptions options;
  const SE3 truth = make_pose(3.1, {0.0, 0.0, 0.0});  // near pi: both signs occur naturally
  DriftEstimate e = initialize_drift(truth, options);
  for (int i = 0; i < 50; ++i) {
    // Same rotation, alternating quaternion sign.
    Eigen::Quaterniond q = truth.quaternion();
    if (i % 2 == 1) q.coeffs() = -q.coeffs();
    const SE3 measured(SO3(q), truth.translation());
    const DriftEstimate before = e;
    e = update_drift(e, measured, options).estimate;
    EXPECT_LT(rotation_distance(e.drift(), truth), 1e-9) << i;
    EXPECT_LT((e.rotation - before.rotation).norm(), 1e-9) << i;  // coefficients continuous
  }
  // Without sign alignment the average of q and -q would collapse towards zero.
  EXPECT_NEAR(e.rotation.norm(), 1.0, 1e-12);
  const Eigen::Vector4d q(0.1, 0.2, 0.3, 0.9);
  EXPECT_EQ(align_quaternion_sign(-q, q), q);
  EXPECT_EQ(align_quaternion_sign(q, q), q);
}

TEST(DriftFilter, GatingRejectsAnOutlierAndCounts) {
  const DriftFilterOptions options;
  const SE3 truth = make_pose(0.1, {1.0, 2.0, 0.0});
  DriftEstimate e = initialize_drift(truth, options);
  for (int i = 0; i < 30; ++i)
    e = update_drift(e, truth, options).estimate;

  const SE3 outlier = make_pose(0.1, {1.5, 2.0, 0.0});  // a 50 cm relocalization error
  const DriftUpdate u = update_drift(e, outlier, options);
  EXPECT_EQ(u.decision, GateDecision::kRejected);
  EXPECT_GT(u.translation_d2, options.gate_chi2);
  EXPECT_EQ(u.estimate.consecutive_rejections, 1);
  EXPECT_LT(translation_distance(u.estimate.drift(), truth), 1e-12);  // unchanged

  const SE3 rotated = make_pose(0.1 + 0.2, {1.0, 2.0, 0.0});  // 11 degrees off
  EXPECT_EQ(update_drift(e, rotated, options).decision, GateDecision::kRejected);

  // The paper's filter (no gate) takes it in: the user would be yanked by gain * 50 cm.
  DriftFilterOptions paper = options;
  paper.gating = false;
  const DriftUpdate p = update_drift(e, outlier, paper);
  EXPECT_EQ(p.decision, GateDecision::kAccepted);
  EXPECT_GT(translation_distance(p.estimate.drift(), truth), 0.01);
}

// A global pose 20 m from D's origin with its position exact and its rotation 0.46 deg off (a
// localizer's ordinary rotation noise): D's translation moves by 0.008 * 20 m = 16 cm, but the
// device was measured where it is. Gated at the device it is taken; at D's origin it was not.
TEST(DriftFilter, GatesTheTranslationWhereTheDeviceIs) {
  const DriftFilterOptions options;
  DriftEstimate e = initialize_drift(SE3(), options);
  for (int i = 0; i < 30; ++i)
    e = update_drift(e, SE3(), options).estimate;
  const SE3 xr_from_head = make_pose(0.0, {20.0, 0.0, 0.0});
  const SE3 world_from_head = xr_from_head * make_pose(0.008, {0.0, 0.0, 0.0});
  const SE3 measured = measure_drift(world_from_head, xr_from_head);
  EXPECT_GT(measured.translation().norm(), 0.15);
  EXPECT_EQ(update_drift(e, measured, options).decision, GateDecision::kRejected);
  const DriftUpdate u = update_drift(e, measured, options, 1.0, xr_from_head.translation());
  EXPECT_EQ(u.decision, GateDecision::kAccepted);
  EXPECT_LT(u.translation_d2, 1e-12);
}

TEST(DriftFilter, RepeatedRejectionsReinitialize) {
  DriftFilterOptions options;
  options.reset_after_rejections = 3;
  const SE3 before = make_pose(0.0, {0.0, 0.0, 0.0});
  const SE3 after = make_pose(0.0, {2.0, 0.0, 0.0});  // the headset was re-centred
  DriftEstimate e = initialize_drift(before, options);
  for (int i = 0; i < 20; ++i)
    e = update_drift(e, before, options).estimate;
  for (int i = 0; i < 3; ++i) {
    const DriftUpdate u = update_drift(e, after, options);
    EXPECT_EQ(u.decision, GateDecision::kRejected);
    e = u.estimate;
  }
  const DriftUpdate u = update_drift(e, after, options);
  EXPECT_EQ(u.decision, GateDecision::kInitialized);
  EXPECT_LT(translation_distance(u.estimate.drift(), after), 1e-12);
}

TEST(DriftFilter, OptionsCheckNamesTheField) {
  DriftFilterOptions options;
  options.measurement_noise = -1.0;
  try {
    options.check();
    FAIL() << "expected coloc::Error";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "DriftFilterOptions.measurement_noise");
  }
}

}  // namespace
}  // namespace coloc::fusion
