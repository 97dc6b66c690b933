// The multi-user simulation's prediction (simulate.hpp) against Monte Carlo: the calibration
// covariance against the scatter of real hand-eye solves, and the fusers' error model against
// what drift-corrected users measure.

#include <gtest/gtest.h>

#include "fusion/session/simulate.hpp"
#include "registration/handeye/simulate.hpp"

namespace coloc::fusion::session {
namespace {

namespace he = registration::handeye;

// vr_from_camera_covariance on seeded 10-registration solves: the mean predicted covariance
// against the scatter of the true errors (truth = estimate * Exp(eps)), per block.
TEST(SessionSimulate, CalibrationCovarianceMatchesTheScatterOfSolves) {
  Matrix6d scatter = Matrix6d::Zero(), predicted = Matrix6d::Zero();
  constexpr int kRuns = 300;
  for (int run = 0; run < kRuns; ++run) {
    he::SimulationOptions so;
    so.num_registrations = 10;
    so.seed = 1000 + static_cast<std::uint64_t>(run);
    const he::Simulation sim = he::simulate(so);
    he::Options ho;
    ho.noise = he::noise_model(so);
    const he::Summary s = he::solve(sim.registrations, ho);
    predicted +=
        vr_from_camera_covariance(sim.registrations, s.used, s.device_from_marker, s.vr_from_camera,
                                  s.device_from_marker_covariance.value_or(Matrix6d::Zero())) /
        kRuns;
    const Vector6d eps = (s.vr_from_camera.inverse() * sim.vr_from_camera).log();
    scatter += eps * eps.transpose() / kRuns;
  }
  // 300 runs: the scatter's trace is known to ~10 %.
  const double translation =
      scatter.topLeftCorner(3, 3).trace() / predicted.topLeftCorner(3, 3).trace();
  const double rotation =
      scatter.bottomRightCorner(3, 3).trace() / predicted.bottomRightCorner(3, 3).trace();
  EXPECT_NEAR(translation, 1.0, 0.2);
  EXPECT_NEAR(rotation, 1.0, 0.2);
}

// Two drift-corrected users (Quest, tablet) beside a VIVE: their pair's measured relative-pose
// error against the fusers' linearized error model (filtered global noise, drift lag), with the
// fusers' gate off so that they are the linear filters the model describes.
TEST(SessionSimulate, FuserErrorModelPredictsCorrectedPairs) {
  for (const bool drift : {false, true}) {
    MultiUserOptions o;
    o.participants = 3;
    o.trials = 3;
    o.duration = 30.0;
    o.drift = drift;
    o.fuser_gating = false;
    const MultiUserReport r = simulate_multi_user(o);
    ASSERT_EQ(r.pairs.size(), 3u);
    const PairError& corrected = r.pairs[2];  // quest1-tablet2
    EXPECT_EQ(corrected.a, "quest1");
    EXPECT_NEAR(corrected.measured_position_rms / corrected.predicted_position_rms, 1.0, 0.15)
        << "drift " << drift;
    EXPECT_NEAR(corrected.measured_rotation_rms / corrected.predicted_rotation_rms, 1.0, 0.15)
        << "drift " << drift;
  }
}

}  // namespace
}  // namespace coloc::fusion::session
