#pragma once
// Absolute and relative trajectory error, defined as the TUM RGB-D benchmark tools
// (evaluate_ate.py / evaluate_rpe.py) and evo (evo_ape / evo_rpe) define them:
//  - poses are associated by timestamp (greedy nearest first, |dt| <= max_dt);
//  - ATE: the estimate is aligned to the ground truth (Umeyama: SE3, Sim3 or none), and the
//    error of pose i is |t_gt_i - t_est_aligned_i| (metres);
//  - RPE: for associated pose pairs (i, i + delta), E = (gt_i^-1 gt_j)^-1 (est_i^-1 est_j); the
//    translation error is |t(E)| (metres) and the rotation error the angle of R(E) (degrees).
// Statistics: RMSE, mean, median, population standard deviation, min, max (numpy's
// definitions, as both tools use).

#include <optional>
#include <vector>

#include "slam/core/sim3.hpp"
#include "slam/core/trajectory.hpp"

namespace coloc::eval {

enum class Alignment { kNone, kSE3, kSim3 };

// Parses "none" | "se3" | "sim3"; throws coloc::Error otherwise.
Alignment parse_alignment(const std::string& name);

struct ErrorStats {
  std::size_t count = 0;
  double rmse = 0.0, mean = 0.0, median = 0.0, std = 0.0, min = 0.0, max = 0.0;
};
ErrorStats compute_stats(const std::vector<double>& errors);

struct AteOptions {
  Alignment alignment = Alignment::kSE3;
  double max_dt = 0.02;  // seconds
};

struct AteResult {
  ErrorStats translation;          // metres
  Sim3 gt_from_est;                // the alignment applied to the estimate
  std::vector<double> timestamps;  // of the associated ground-truth poses
  std::vector<double> errors;      // per associated pose, metres
  Trajectory ground_truth;         // associated ground-truth poses
  Trajectory estimate_aligned;     // associated estimated poses after alignment
};

// Throws coloc::Error when fewer than 3 poses associate or the alignment is degenerate.
AteResult compute_ate(const Trajectory& ground_truth, const Trajectory& estimate,
                      const AteOptions& options = {});

struct RpeOptions {
  Alignment alignment = Alignment::kNone;  // relative errors are invariant to SE3 alignment
  double max_dt = 0.02;                    // seconds
  std::size_t delta = 1;                   // pose pairs (i, i + delta) among associated poses
};

struct RpeResult {
  ErrorStats translation;          // metres
  ErrorStats rotation;             // degrees
  std::vector<double> timestamps;  // of pose i of each pair
  std::vector<double> translation_errors;
  std::vector<double> rotation_errors;
};

// The pose of `trajectory` nearest in time to `timestamp`, if one is within max_dt.
std::optional<SE3> nearest_pose(const Trajectory& trajectory, double timestamp,
                                double max_dt = 0.02);

// How far an estimated relative pose b_from_a (e.g. what a loop closure asserted between two
// keyframes) is from the truth: translation (metres) and rotation (degrees) of
// (gt_b^-1 gt_a)^-1 b_from_a. Empty when either time has no ground truth within max_dt.
struct PoseError {
  double translation = 0.0, rotation_deg = 0.0;
};
std::optional<PoseError> relative_pose_error(const Trajectory& ground_truth, double time_a,
                                             double time_b, const SE3& b_from_a,
                                             double max_dt = 0.02);

RpeResult compute_rpe(const Trajectory& ground_truth, const Trajectory& estimate,
                      const RpeOptions& options = {});

}  // namespace coloc::eval
