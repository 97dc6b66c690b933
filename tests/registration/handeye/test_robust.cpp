// Robust mode, refinement accuracy and uncertainty on noisy synthetic sessions.

#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "registration/handeye/handeye.hpp"
#include "registration/handeye/simulate.hpp"
#include "slam/core/timing.hpp"

namespace coloc::registration::handeye {
namespace {

TEST(HandeyeRobust, OutliersRejectedByRansac) {
  int all_found = 0;
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    SimulationOptions o;
    o.seed = seed;
    o.num_registrations = 10;
    o.outlier_fraction = 0.2;
    const Simulation sim = simulate(o);
    Options options;
    options.robust = true;
    const Summary s = solve(sim.registrations, options);
    ASSERT_TRUE(s.is_solution_usable()) << s.message;
    bool exact = true;
    for (std::size_t k = 0; k < sim.is_outlier.size(); ++k)
      exact &= s.used[k] != sim.is_outlier[k];
    all_found += exact;
    const PoseError e = pose_error(s.device_from_marker, sim.device_from_marker);
    EXPECT_LT(e.rotation, 0.01) << "seed " << seed;
    EXPECT_LT(e.translation, 0.02) << "seed " << seed;
  }
  EXPECT_GE(all_found, 19);
}

TEST(HandeyeRobust, NotUsableWhenMostRegistrationsDisagree) {
  SimulationOptions o;
  o.seed = 2;
  o.outlier_fraction = 0.7;
  const Simulation sim = simulate(o);
  Options options;
  options.robust = true;
  const Summary s = solve(sim.registrations, options);
  EXPECT_FALSE(s.is_solution_usable());
  EXPECT_FALSE(s.message.empty());
}

// The covariance predicts the actual error: the normalized squared error (NEES, 6 dof) averages
// close to 6 over many sessions.
TEST(HandeyeUncertainty, CovarianceIsConsistent) {
  std::vector<double> nees;
  for (std::uint64_t seed = 1; seed <= 200; ++seed) {
    SimulationOptions o;
    o.seed = seed;
    const Simulation sim = simulate(o);
    Options options;
    options.noise = noise_model(o);
    const Summary s = solve(sim.registrations, options);
    ASSERT_TRUE(s.device_from_marker_covariance.has_value());
    // Error in the covariance's tangent: X_est = (Exp(d_theta) R_true, t_true + d_t).
    Vector6d e;
    e.head<3>() = s.device_from_marker.translation() - sim.device_from_marker.translation();
    e.tail<3>() = (s.device_from_marker.so3() * sim.device_from_marker.so3().inverse()).log();
    nees.push_back(e.dot(s.device_from_marker_covariance->ldlt().solve(e)));
  }
  const double mean = summarize(nees).mean;
  EXPECT_GT(mean, 6.0 / 2.0);
  EXPECT_LT(mean, 6.0 * 2.0);
}

}  // namespace
}  // namespace coloc::registration::handeye
