// Accuracy against every cv::calibrateHandEye method at the same noise (OpenCV's own protocol:
// 10 poses, 0.002 rad / 5 mm on the marker pose, 0.001 rad / 1 mm on the device pose), a noise
// sweep, unknown scale, and 10 % outlier registrations in robust mode.

#include <gtest/gtest.h>

#include <cstdio>

#include "registration/handeye/opencv/compare.hpp"
#include "slam/core/timing.hpp"

namespace coloc::registration::handeye {
namespace {

double median(const std::vector<double>& v) {
  return quantile(v, 0.5);
}

void print(const std::vector<MethodErrors>& methods, const char* title) {
  std::printf("%s\n", title);
  for (const MethodErrors& m : methods) {
    std::printf("  %-20s rot median %.4f deg p90 %.4f deg | trans median %.3f mm p90 %.3f mm\n",
                m.name.c_str(), median(m.rotation) * 57.29578, quantile(m.rotation, 0.9) * 57.29578,
                median(m.translation) * 1e3, quantile(m.translation, 0.9) * 1e3);
  }
}

bool is_opencv(const MethodErrors& m) {
  return m.name.rfind("opencv-", 0) == 0;
}

const MethodErrors& bound(const std::vector<MethodErrors>& methods) {
  for (const MethodErrors& m : methods)
    if (m.name == kCramerRaoName) return m;
  ADD_FAILURE() << "no Cramer-Rao row";
  return methods.front();
}

// Strictly lower median errors than every OpenCV method.
void expect_better_than_opencv(const std::vector<MethodErrors>& methods) {
  for (const MethodErrors& m : methods) {
    if (!is_opencv(m)) continue;
    EXPECT_LT(median(methods[0].rotation), median(m.rotation)) << m.name;
    EXPECT_LT(median(methods[0].translation), median(m.translation)) << m.name;
  }
}

// At isotropic Gaussian noise OpenCV's PARK (all pairs i < j, like the paper's linear stage) is
// itself at the Cramer-Rao bound: its median and RMS errors are within ~1 % of the bound's, as
// are ours (maximum likelihood over the absolute poses). No unbiased estimator can then beat it
// by more than the sampling noise of a 100-trial median (~4 %), so against PARK, HORAUD and
// ANDREFF we assert parity (median within 5 %) and the bound itself in AtTheCramerRaoBound.
void expect_at_least_par(const std::vector<MethodErrors>& methods) {
  for (const MethodErrors& m : methods) {
    if (!is_opencv(m)) continue;
    EXPECT_LT(median(methods[0].rotation), 1.05 * median(m.rotation)) << m.name;
    EXPECT_LT(median(methods[0].translation), 1.05 * median(m.translation)) << m.name;
  }
}

// Median errors within `tolerance` (relative) of those of an efficient estimator.
void expect_at_bound(const std::vector<MethodErrors>& methods, double tolerance) {
  const MethodErrors& b = bound(methods);
  EXPECT_LT(median(methods[0].rotation), (1.0 + tolerance) * median(b.rotation));
  EXPECT_LT(median(methods[0].translation), (1.0 + tolerance) * median(b.translation));
}

TEST(HandeyeVsOpencv, OpencvProtocol) {
  SimulationOptions s;  // defaults are OpenCV's protocol noise
  s.seed = 1000;
  const auto methods = compare_methods(s, 100, Options{}, "ours", true);
  print(methods, "OpenCV protocol, 100 trials of 10 registrations");
  expect_at_least_par(methods);
  for (const char* weaker : {"opencv-TSAI", "opencv-DANIILIDIS"}) {
    for (const MethodErrors& m : methods) {
      if (m.name != weaker) continue;
      EXPECT_LT(median(methods[0].rotation), median(m.rotation)) << weaker;
      EXPECT_LT(median(methods[0].translation), median(m.translation)) << weaker;
    }
  }
}

// 1000 sessions at the protocol noise: ours is at the Cramer-Rao bound (the best any unbiased
// estimator can do on these sessions). On this seed ours has the lowest medians of all (rotation
// 0.1035 deg vs PARK 0.1042, translation 4.028 mm vs 4.061), but the expected gap to PARK, HORAUD
// and ANDREFF is below 1 % (2000-session runs), under the sampling noise of any affordable trial
// count, so those three are asserted within 2 % and TSAI and DANIILIDIS strictly.
TEST(HandeyeVsOpencv, AtTheCramerRaoBound) {
  SimulationOptions s;
  s.seed = 7000;
  const auto methods = compare_methods(s, 1000, Options{}, "ours", true);
  print(methods, "OpenCV protocol, 1000 trials of 10 registrations");
  expect_at_bound(methods, 0.03);
  for (const MethodErrors& m : methods) {
    if (!is_opencv(m)) continue;
    const bool near_bound =
        m.name != std::string("opencv-TSAI") && m.name != std::string("opencv-DANIILIDIS");
    const double margin = near_bound ? 1.02 : 1.0;
    EXPECT_LT(median(methods[0].rotation), margin * median(m.rotation)) << m.name;
    EXPECT_LT(median(methods[0].translation), margin * median(m.translation)) << m.name;
  }
}

// PnP measures depth worst: with 15 mm extra noise along the viewing ray the estimated noise
// model lets the refinement weight it down, and ours wins on translation against every method.
TEST(HandeyeVsOpencv, DepthDominatedPnpNoise) {
  SimulationOptions s;
  s.seed = 1500;
  s.marker_depth_noise = 0.015;
  const auto methods = compare_methods(s, 100, Options{}, "ours", true);
  print(methods, "OpenCV protocol + 15 mm depth noise");
  expect_at_least_par(methods);
  EXPECT_LT(median(methods[0].translation), 1.03 * median(bound(methods).translation));
  for (const MethodErrors& m : methods) {
    if (!is_opencv(m)) continue;
    EXPECT_LT(median(methods[0].translation), 0.85 * median(m.translation)) << m.name;
  }
}

TEST(HandeyeVsOpencv, NoiseSweep) {
  for (double factor : {0.25, 1.0, 4.0}) {
    SimulationOptions s;
    s.seed = 2000;
    s.device_rotation_noise *= factor;
    s.device_translation_noise *= factor;
    s.marker_rotation_noise *= factor;
    s.marker_translation_noise *= factor;
    const auto methods = compare_methods(s, 60, Options{}, "ours", true);
    print(methods, ("noise x" + std::to_string(factor)).c_str());
    expect_at_least_par(methods);
  }
}

TEST(HandeyeVsOpencv, UnknownScale) {
  SimulationOptions s;
  s.seed = 3000;
  s.scale = 0.8;
  Options o;
  o.estimate_scale = true;
  const auto methods = compare_methods(s, 60, o, "ours (sigma)", false);
  EXPECT_LT(median(methods[0].sigma), 0.01);
  EXPECT_LT(median(methods[0].translation), 0.006);
}

// With 10 % outlier registrations, robust mode stays within 2x of its outlier-free error, and
// beats every OpenCV method run on the contaminated data.
TEST(HandeyeVsOpencv, TenPercentOutliersRobust) {
  SimulationOptions clean;
  clean.seed = 4000;
  clean.num_registrations = 20;
  Options robust;
  robust.robust = true;
  const auto reference = compare_methods(clean, 80, robust, "ours robust, 0 %", false);
  SimulationOptions dirty = clean;
  dirty.outlier_fraction = 0.1;
  const auto methods = compare_methods(dirty, 80, robust, "ours robust, 10 %", true);
  print(reference, "outlier-free reference");
  print(methods, "10 % outliers");
  EXPECT_LT(median(methods[0].rotation), 2.0 * median(reference[0].rotation));
  EXPECT_LT(median(methods[0].translation), 2.0 * median(reference[0].translation));
  expect_better_than_opencv(methods);
}

}  // namespace
}  // namespace coloc::registration::handeye
