#pragma once
// The paper's least-squares stage (An et al. 2023, section III.D-E), exposed for RANSAC, the
// guidance and the tests. Frames as in handeye.hpp.

#include <span>
#include <vector>

#include "registration/handeye/handeye.hpp"

namespace coloc::registration::handeye {

// One relative motion pair of A_ij X = X B_ij built from registrations i and j.
struct MotionPair {
  SE3 a;  // A_ij (device-side motion; see Target)
  SE3 b;  // B_ij (marker-side motion, translation as measured, i.e. before sigma)
  int i = 0;
  int j = 0;
};

// A_ij, B_ij for the given target; `indices` selects registrations (in order).
MotionPair make_motion_pair(const Registration& ri, const Registration& rj, Target target);

// Pairs for the selected registrations, after the angle-consistency test. `used` (one flag per
// registration, size = registrations.size()) is updated: registrations dropped by the test are
// cleared. Counts go to `conditioning`.
std::vector<MotionPair> build_pairs(std::span<const Registration> registrations,
                                    std::vector<bool>& used, const Options& options,
                                    Conditioning& conditioning);

enum class LinearStatus {
  kOk,
  kTooFewRegistrations,  // fewer than 3 usable registrations
  kTooSmallRotations,    // every pair rotated less than min_pair_rotation
  kSingleAxis,           // all rotation axes (nearly) parallel
  kTranslationSingular,  // translation system rank deficient
};

// The advice shown to a user for a status ("rotate the controller about a different axis").
std::string advice(LinearStatus status, const Options& options);

struct LinearSolution {
  LinearStatus status = LinearStatus::kOk;
  SE3 x;  // the target unknown (device_from_marker or vr_from_camera)
  double sigma = 1.0;
};

// R_X = polar factor of M^T, M = sum(w_B w_A^T) (equal to (M^T M)^-1/2 M^T when det M > 0,
// computed by SVD so that a rank-2 M from two axes still gives the unique rotation); then t_X
// (and sigma) by linear least squares on (R_A - I) t_X - sigma R_X t_B = -t_A.
LinearSolution solve_linear(std::span<const MotionPair> pairs, const Options& options,
                            Conditioning& conditioning);

// Given one unknown, the other: device_from_marker <-> vr_from_camera, averaged over the used
// registrations (chordal L2 mean of rotations, mean of translations).
SE3 other_unknown(std::span<const Registration> registrations, const std::vector<bool>& used,
                  const SE3& x, double sigma, Target target);

// camera_from_marker with its translation multiplied by sigma.
SE3 scaled(const SE3& camera_from_marker, double sigma);

}  // namespace coloc::registration::handeye
