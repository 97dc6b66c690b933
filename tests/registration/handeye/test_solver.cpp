// The least-squares solver: exact recovery, conventions, degenerate input, options.

#include <gtest/gtest.h>

#include <numbers>
#include <random>

#include "registration/handeye/compose.hpp"
#include "registration/handeye/handeye.hpp"
#include "registration/handeye/linear.hpp"
#include "registration/handeye/refine.hpp"
#include "registration/handeye/simulate.hpp"
#include "slam/core/error.hpp"

namespace coloc::registration::handeye {
namespace {

SimulationOptions noise_free(std::uint64_t seed = 3) {
  SimulationOptions o;
  o.device_rotation_noise = o.device_translation_noise = 0.0;
  o.marker_rotation_noise = o.marker_translation_noise = 0.0;
  o.seed = seed;
  return o;
}

void expect_near(const SE3& a, const SE3& b, double tolerance) {
  EXPECT_LT(angular_distance(a.so3(), b.so3()), tolerance);
  EXPECT_LT((a.translation() - b.translation()).norm(), tolerance);
}

// The simulator follows the physical chain: vr_from_device * X * camera_from_marker^-1 is the
// true vr_from_camera for every registration (this pins the frame conventions).
TEST(HandeyeSimulate, PhysicalChainIsConsistent) {
  const Simulation sim = simulate(noise_free());
  for (const SE3& c2v :
       vr_from_camera_per_registration(sim.registrations, sim.device_from_marker)) {
    expect_near(c2v, sim.vr_from_camera, 1e-12);
  }
  // The marker faces the camera: its z axis points back towards the camera (PnP convention).
  for (const Registration& r : sim.registrations) {
    const Eigen::Vector3d z_in_camera = r.camera_from_marker.rotation().col(2);
    EXPECT_LT(z_in_camera.dot(r.camera_from_marker.translation().normalized()), 0.0);
  }
}

struct ExactCase {
  Target target;
  PairMode pairs;
  bool refine;
};

class HandeyeExact : public ::testing::TestWithParam<ExactCase> {};

TEST_P(HandeyeExact, NoiseFreeRecoveredTo1e9) {
  for (std::uint64_t seed : {1, 2, 3, 4, 5}) {
    const Simulation sim = simulate(noise_free(seed));
    Options options;
    options.target = GetParam().target;
    options.pairs = GetParam().pairs;
    options.refine = GetParam().refine;
    options.estimate_covariance = GetParam().refine;
    const Summary s = solve(sim.registrations, options);
    ASSERT_TRUE(s.is_solution_usable()) << s.message;
    expect_near(s.device_from_marker, sim.device_from_marker, 1e-9);
    expect_near(s.vr_from_camera, sim.vr_from_camera, 1e-9);
    EXPECT_EQ(s.num_used, 10);
    EXPECT_LT(s.residuals.translation_rms, 1e-9);
    EXPECT_EQ(s.conditioning.pairs_rejected, 0);
    EXPECT_GT(s.conditioning.axis_spread, 0.5);
    EXPECT_GT(s.conditioning.translation_min_singular_value, 0.1);
  }
}

INSTANTIATE_TEST_SUITE_P(
    Modes, HandeyeExact,
    ::testing::Values(ExactCase{Target::kDeviceFromMarker, PairMode::kAll, false},
                      ExactCase{Target::kVrFromCamera, PairMode::kAll, false},
                      ExactCase{Target::kDeviceFromMarker, PairMode::kConsecutive, false},
                      ExactCase{Target::kVrFromCamera, PairMode::kConsecutive, false},
                      ExactCase{Target::kDeviceFromMarker, PairMode::kAll, true}));

TEST(HandeyeSolver, ThreeRegistrationsSuffice) {
  SimulationOptions o = noise_free(11);
  o.num_registrations = 3;
  const Simulation sim = simulate(o);
  Options options;
  options.refine = false;
  options.estimate_covariance = false;
  const Summary s = solve(sim.registrations, options);
  expect_near(s.device_from_marker, sim.device_from_marker, 1e-9);
}

TEST(HandeyeSolver, UnknownScaleRecovered) {
  SimulationOptions o = noise_free(5);
  o.scale = 1.37;  // e.g. a 5 cm marker entered as 3.65 cm
  const Simulation sim = simulate(o);
  for (bool refine : {false, true}) {
    Options options;
    options.estimate_scale = true;
    options.refine = refine;
    options.estimate_covariance = refine;
    const Summary s = solve(sim.registrations, options);
    EXPECT_NEAR(s.sigma, 1.37, 1e-9);
    EXPECT_TRUE(s.scale_estimated);
    expect_near(s.device_from_marker, sim.device_from_marker, 1e-9);
  }
  // Without estimating it, a wrong scale shows up as translation residuals.
  Options fixed;
  const Summary s = solve(sim.registrations, fixed);
  EXPECT_GT(s.residuals.translation_rms, 1e-3);
}

// The camera-on-headset variant: vr_from_headset * headset_from_camera * camera_from_board is
// constant (a board fixed in the room).
TEST(HandeyeSolver, CameraOnHeadset) {
  const SE3 headset_from_camera(SO3::exp(Eigen::Vector3d(0.1, -0.3, 0.05)),
                                Eigen::Vector3d(0.04, -0.02, 0.07));
  const SE3 vr_from_board(SO3::exp(Eigen::Vector3d(1.2, 0.1, -0.4)), Eigen::Vector3d(1, 2, 0.5));
  const Simulation motion = simulate(noise_free(9));  // reuse its controller poses as headset poses
  std::vector<Registration> registrations;
  for (const SE3& world_from_headset : motion.world_from_device) {
    const SE3 vr_from_headset = world_from_headset;
    const SE3 camera_from_board = (vr_from_headset * headset_from_camera).inverse() * vr_from_board;
    registrations.push_back(headset_registration(vr_from_headset, camera_from_board));
  }
  const Summary s = solve(registrations);
  expect_near(s.device_from_marker, headset_from_camera, 1e-9);
  expect_near(s.vr_from_camera, vr_from_board, 1e-9);
}

TEST(HandeyeSolver, TooFewRegistrationsRejectedWithAdvice) {
  const Simulation sim = simulate(noise_free());
  try {
    solve(std::span(sim.registrations).first(2));
    FAIL() << "expected coloc::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("add registrations"), std::string::npos) << e.what();
    EXPECT_EQ(e.context().field, "registrations");
  }
}

// Rotations about one axis only: the paper's theorem needs two different axes.
TEST(HandeyeSolver, SingleAxisRejectedWithAdvice) {
  const SE3 x(SO3::exp(Eigen::Vector3d(0.3, 0.2, 0.1)), Eigen::Vector3d(0.05, 0.01, 0.02));
  const SE3 vr_from_camera(SO3::exp(Eigen::Vector3d(0, 0, 1)), Eigen::Vector3d(1, 0, 1));
  std::vector<Registration> registrations;
  for (int i = 0; i < 6; ++i) {
    const SE3 vr_from_device(SO3::exp(Eigen::Vector3d(0, 0, 0.4 * i)),
                             Eigen::Vector3d(0.1 * i, 0.0, 1.0));
    registrations.push_back({vr_from_device, (vr_from_camera.inverse() * vr_from_device * x)});
  }
  try {
    solve(registrations);
    FAIL() << "expected coloc::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("rotate the controller about a different axis"),
              std::string::npos)
        << e.what();
  }
}

TEST(HandeyeSolver, TinyRotationsRejectedWithAdvice) {
  const SE3 x(SO3::exp(Eigen::Vector3d(0.3, 0.2, 0.1)), Eigen::Vector3d(0.05, 0.01, 0.02));
  std::vector<Registration> registrations;
  for (int i = 0; i < 6; ++i) {
    const SE3 vr_from_device(SO3::exp(Eigen::Vector3d(0.004 * i, -0.003 * i, 0.002 * (i % 2))),
                             Eigen::Vector3d(0.1 * i, 0.0, 1.0));
    registrations.push_back({vr_from_device, (vr_from_device * x)});
  }
  try {
    solve(registrations);
    FAIL() << "expected coloc::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("barely rotated"), std::string::npos) << e.what();
  }
}

TEST(HandeyeSolver, InconsistentRotationAnglesDropped) {
  SimulationOptions o = noise_free(21);
  const Simulation sim = simulate(o);
  std::vector<Registration> registrations = sim.registrations;
  // Registration 4: the marker pose comes from another instant (rotated 20 degrees).
  registrations[4].camera_from_marker =
      SE3(SO3::exp(Eigen::Vector3d(0.35, 0, 0)), Eigen::Vector3d::Zero()) *
      registrations[4].camera_from_marker;
  Options options;
  const Summary s = solve(registrations, options);
  EXPECT_FALSE(s.used[4]);
  EXPECT_EQ(s.num_used, 9);
  EXPECT_GT(s.conditioning.pairs_rejected, 0);
  expect_near(s.device_from_marker, sim.device_from_marker, 1e-9);
}

TEST(HandeyeOptions, CheckNamesTheField) {
  Options options;
  options.max_angle_mismatch = -1;
  try {
    options.check();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "max_angle_mismatch");
  }
  Options o2;
  o2.refine = false;  // covariance needs the refinement
  EXPECT_THROW(o2.check(), Error);
  SimulationOptions so;
  so.scale = 0;
  EXPECT_THROW(so.check(), Error);
}

// The Cramer-Rao bound is evaluated at the truth, so it does not depend on the noise draws: it
// scales with the noise variance, and the empirical scatter of our estimates over many noise
// draws on one geometry is at the bound (maximum likelihood is efficient here).
TEST(HandeyeBound, ScalesWithNoiseAndMatchesTheScatter) {
  SimulationOptions o;
  o.seed = 11;
  const Simulation sim = simulate(o);
  const std::vector<bool> used(sim.registrations.size(), true);
  NoiseModel noise = noise_model(o);
  const auto bound = cramer_rao_bound(sim.registrations, used, sim.device_from_marker,
                                      sim.vr_from_camera, 1.0, noise);
  ASSERT_TRUE(bound.has_value());
  EXPECT_GT((bound->topLeftCorner<3, 3>().trace()), 0.0);
  noise.device_rotation *= 2;
  noise.device_translation *= 2;
  noise.marker_rotation *= 2;
  noise.marker_translation *= 2;
  const auto doubled = cramer_rao_bound(sim.registrations, used, sim.device_from_marker,
                                        sim.vr_from_camera, 1.0, noise);
  ASSERT_TRUE(doubled.has_value());
  EXPECT_LT((*doubled - 4.0 * *bound).norm(), 1e-9 * bound->norm() + 1e-15);

  // One geometry (a noise-free session), many noise draws of the protocol noise made here.
  SimulationOptions clean = o;
  clean.device_rotation_noise = clean.device_translation_noise = 0.0;
  clean.marker_rotation_noise = clean.marker_translation_noise = 0.0;
  const Simulation truth = simulate(clean);
  std::mt19937_64 rng(5);
  std::normal_distribution<double> normal;
  auto draw = [&](double s) {
    Eigen::Vector3d v;
    for (int a = 0; a < 3; ++a)
      v[a] = s * normal(rng);
    return v;
  };
  double rotation = 0.0, translation = 0.0;
  constexpr int kDraws = 400;
  for (int k = 0; k < kDraws; ++k) {
    std::vector<Registration> noisy = truth.registrations;
    for (Registration& r : noisy) {
      r.vr_from_device = SE3(r.vr_from_device.so3() * SO3::exp(draw(o.device_rotation_noise)),
                             r.vr_from_device.translation() + draw(o.device_translation_noise));
      r.camera_from_marker =
          SE3(r.camera_from_marker.so3() * SO3::exp(draw(o.marker_rotation_noise)),
              r.camera_from_marker.translation() + draw(o.marker_translation_noise));
    }
    const PoseError e =
        pose_error(solve(noisy, Options{}).device_from_marker, truth.device_from_marker);
    rotation += e.rotation * e.rotation / kDraws;
    translation += e.translation * e.translation / kDraws;
  }
  const auto truth_bound = cramer_rao_bound(truth.registrations, used, truth.device_from_marker,
                                            truth.vr_from_camera, 1.0, noise_model(o));
  ASSERT_TRUE(truth_bound.has_value());
  // 400 draws: the mean square is known to ~7 % (chi^2 with ~1200 dof), plus the finite-sample
  // excess of the estimated noise weights.
  EXPECT_NEAR(std::sqrt(translation / truth_bound->topLeftCorner<3, 3>().trace()), 1.0, 0.12);
  EXPECT_NEAR(std::sqrt(rotation / truth_bound->bottomRightCorner<3, 3>().trace()), 1.0, 0.12);
}

}  // namespace
}  // namespace coloc::registration::handeye
