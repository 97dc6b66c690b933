// The VR device noise from real data: a static HTC Vive tracker logged for 20 minutes at 5 Hz
// (../shared/data/vive_tracker_vs_lasertracker, 3x4 row-major vr_from_tracker per line). Its
// jitter becomes the device noise of a simulated session, where ours must stay at least on par
// with every OpenCV method.

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <sstream>

#include "registration/handeye/compose.hpp"
#include "registration/handeye/opencv/compare.hpp"
#include "slam/core/timing.hpp"
#include "tests/testing/data.hpp"

namespace coloc::registration::handeye {
namespace {

std::vector<SE3> read_vive_log(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::vector<SE3> poses;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    Eigen::Matrix<double, 3, 4> m;
    for (int k = 0; k < 12; ++k)
      fields >> m(k / 4, k % 4);
    if (fields) poses.push_back(SE3::from_matrix3x4(m));
  }
  return poses;
}

TEST(HandeyeViveNoise, MeasuredJitterAsDeviceNoise) {
  COLOC_REQUIRE_DATA(path,
                     "vive_tracker_vs_lasertracker/20201002_Exp1_Drift/drift20minExperiment.txt");
  const std::vector<SE3> poses = read_vive_log(path);
  ASSERT_GT(poses.size(), 5000u);
  // Jitter: the spread within the first 10 s (50 samples); drift: last 10 s vs first 10 s.
  const std::span<const SE3> all(poses);
  const Dispersion first = dispersion(all.first(50));
  const Dispersion last = dispersion(all.last(50));
  const double rotation_jitter = first.rotation_rms / std::sqrt(3.0);  // per axis
  const double translation_jitter = first.translation_rms / std::sqrt(3.0);
  std::printf(
      "Vive static tracker: jitter per axis %.4f deg, %.3f mm; 20-min drift %.4f deg, "
      "%.3f mm\n",
      rotation_jitter * 57.29578, translation_jitter * 1e3,
      rotation_distance(first.mean, last.mean) * 57.29578,
      translation_distance(first.mean, last.mean) * 1e3);
  EXPECT_LT(rotation_jitter, 0.01);      // sub-degree
  EXPECT_LT(translation_jitter, 0.005);  // a few mm at most

  SimulationOptions s;
  s.seed = 5000;
  s.device_rotation_noise = rotation_jitter;
  s.device_translation_noise = translation_jitter;
  const auto methods = compare_methods(s, 100, Options{}, "ours", true);
  const double ours_rotation = quantile(methods[0].rotation, 0.5);
  const double ours_translation = quantile(methods[0].translation, 0.5);
  for (const MethodErrors& m : methods) {
    std::printf("  %-20s rot median %.4f deg | trans median %.3f mm\n", m.name.c_str(),
                quantile(m.rotation, 0.5) * 57.29578, quantile(m.translation, 0.5) * 1e3);
    EXPECT_LT(ours_rotation, 1.05 * quantile(m.rotation, 0.5)) << m.name;
    EXPECT_LT(ours_translation, 1.05 * quantile(m.translation, 0.5)) << m.name;
  }
}

}  // namespace
}  // namespace coloc::registration::handeye
