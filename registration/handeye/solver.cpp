// solve(): validation, optional RANSAC, the paper's linear stage, Ceres refinement, residuals.

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>

#include "registration/handeye/compose.hpp"
#include "registration/handeye/handeye.hpp"
#include "registration/handeye/linear.hpp"
#include "registration/handeye/refine.hpp"
#include "slam/core/error.hpp"

namespace coloc::registration::handeye {

namespace {

void require(bool condition, const char* field, const std::string& what) {
  if (!condition)
    throw Error(std::string("handeye option ") + field + ": " + what, {.field = field});
}

bool finite(const SE3& pose) {
  return pose.translation().allFinite() && pose.quaternion().coeffs().allFinite();
}

struct Estimate {
  SE3 device_from_marker;
  SE3 vr_from_camera;
  double sigma = 1.0;
};

// Both unknowns from the linear solution of the target unknown.
Estimate complete(std::span<const Registration> registrations, const std::vector<bool>& used,
                  const LinearSolution& linear, Target target) {
  Estimate e;
  e.sigma = linear.sigma;
  const SE3 other = other_unknown(registrations, used, linear.x, linear.sigma, target);
  if (target == Target::kDeviceFromMarker) {
    e.device_from_marker = linear.x;
    e.vr_from_camera = other;
  } else {
    e.vr_from_camera = linear.x;
    e.device_from_marker = other;
  }
  return e;
}

// Linear solution on the registrations flagged in `used` (updated by the angle test); returns
// the status so that RANSAC can skip degenerate samples.
LinearStatus solve_subset(std::span<const Registration> registrations, std::vector<bool>& used,
                          const Options& options, Conditioning& conditioning, Estimate& estimate) {
  const std::vector<MotionPair> pairs = build_pairs(registrations, used, options, conditioning);
  if (std::count(used.begin(), used.end(), true) < 3) return LinearStatus::kTooFewRegistrations;
  const LinearSolution linear = solve_linear(pairs, options, conditioning);
  if (linear.status != LinearStatus::kOk) return linear.status;
  if (!(linear.sigma > 0.0)) return LinearStatus::kTranslationSingular;
  estimate = complete(registrations, used, linear, options.target);
  return LinearStatus::kOk;
}

// The next triple to try: all of them in order when few, else random distinct ones.
class TripleSampler {
 public:
  TripleSampler(int n, const RansacOptions& options) : n_(n), rng_(options.seed) {
    const long long count = static_cast<long long>(n) * (n - 1) * (n - 2) / 6;
    exhaustive_ = count <= options.max_iterations;
    remaining_ = exhaustive_ ? static_cast<int>(count) : options.max_iterations;
  }
  bool next(std::array<int, 3>& triple) {
    if (remaining_-- <= 0) return false;
    if (exhaustive_) {
      triple = current_;
      advance();
      return true;
    }
    std::uniform_int_distribution<int> pick(0, n_ - 1);
    triple[0] = pick(rng_);
    do
      triple[1] = pick(rng_);
    while (triple[1] == triple[0]);
    do
      triple[2] = pick(rng_);
    while (triple[2] == triple[0] || triple[2] == triple[1]);
    return true;
  }

 private:
  void advance() {
    if (++current_[2] < n_) return;
    if (++current_[1] < n_ - 1) {
      current_[2] = current_[1] + 1;
      return;
    }
    ++current_[0];
    current_[1] = current_[0] + 1;
    current_[2] = current_[1] + 1;
  }
  int n_;
  std::mt19937_64 rng_;
  bool exhaustive_ = true;
  int remaining_ = 0;
  std::array<int, 3> current_ = {0, 1, 2};
};

std::vector<bool> classify(std::span<const Registration> registrations, const Estimate& e,
                           const RansacOptions& ransac, double& cost) {
  std::vector<bool> inliers(registrations.size(), false);
  cost = 0.0;
  for (std::size_t k = 0; k < registrations.size(); ++k) {
    const auto [rotation, translation] =
        registration_residual(registrations[k], e.device_from_marker, e.vr_from_camera, e.sigma);
    const double r = rotation / ransac.inlier_rotation;
    const double t = translation / ransac.inlier_translation;
    inliers[k] = r < 1.0 && t < 1.0;
    cost += std::min(1.0, std::max(r * r, t * t));  // MSAC: truncated cost
  }
  return inliers;
}

// RANSAC over minimal sets of 3 registrations. Returns the best consensus set (empty if no
// triple gave a non-degenerate solution).
std::vector<bool> ransac(std::span<const Registration> registrations, const Options& options) {
  const int n = static_cast<int>(registrations.size());
  TripleSampler sampler(n, options.ransac);
  std::array<int, 3> triple{};
  std::vector<bool> best;
  double best_cost = std::numeric_limits<double>::infinity();
  Options minimal = options;
  minimal.max_bad_pair_fraction = 1.0;  // with 3 registrations, one bad pair is decisive anyway
  while (sampler.next(triple)) {
    std::vector<bool> used(n, false);
    for (int k : triple)
      used[k] = true;
    Conditioning conditioning;
    Estimate estimate;
    if (solve_subset(registrations, used, minimal, conditioning, estimate) != LinearStatus::kOk ||
        conditioning.pairs_rejected > 0) {
      continue;
    }
    double cost = 0.0;
    std::vector<bool> inliers = classify(registrations, estimate, options.ransac, cost);
    if (cost < best_cost) {
      best_cost = cost;
      best = std::move(inliers);
    }
  }
  return best;
}

Residuals compute_residuals(std::span<const Registration> registrations,
                            const std::vector<bool>& used, const Estimate& e) {
  Residuals out;
  int count = 0;
  for (std::size_t k = 0; k < registrations.size(); ++k) {
    const auto [rotation, translation] =
        registration_residual(registrations[k], e.device_from_marker, e.vr_from_camera, e.sigma);
    out.rotation.push_back(rotation);
    out.translation.push_back(translation);
    if (!used[k]) continue;
    out.rotation_rms += rotation * rotation;
    out.translation_rms += translation * translation;
    ++count;
  }
  if (count > 0) {
    out.rotation_rms = std::sqrt(out.rotation_rms / count);
    out.translation_rms = std::sqrt(out.translation_rms / count);
  }
  return out;
}

[[noreturn]] void throw_degenerate(LinearStatus status, const Options& options,
                                   const Conditioning& conditioning) {
  std::ostringstream out;
  out << "hand-eye input is degenerate: " << advice(status, options);
  if (conditioning.pairs_rejected > 0) {
    out << " (" << conditioning.pairs_rejected
        << " pairs failed the angle-consistency test: check that the marker is rigidly fixed and "
           "that device and marker poses are matched in time)";
  }
  throw Error(out.str(), {.field = "registrations"});
}

}  // namespace

void Options::check() const {
  require(max_angle_mismatch > 0, "max_angle_mismatch", "must be > 0 (radians)");
  require(min_pair_rotation >= 0, "min_pair_rotation", "must be >= 0 (radians)");
  require(min_axis_spread >= 0 && min_axis_spread < 3.2, "min_axis_spread",
          "must be in [0, pi] (radians)");
  require(max_bad_pair_fraction > 0 && max_bad_pair_fraction <= 1, "max_bad_pair_fraction",
          "must be in (0, 1]");
  require(ransac.max_iterations > 0, "ransac.max_iterations", "must be > 0");
  require(ransac.inlier_rotation > 0, "ransac.inlier_rotation", "must be > 0 (radians)");
  require(ransac.inlier_translation > 0, "ransac.inlier_translation", "must be > 0 (metres)");
  require(ransac.min_inlier_fraction > 0 && ransac.min_inlier_fraction <= 1,
          "ransac.min_inlier_fraction", "must be in (0, 1]");
  require(max_refine_iterations > 0, "max_refine_iterations", "must be > 0");
  require(noise_estimation_rounds >= 0, "noise_estimation_rounds", "must be >= 0");
  require(noise.device_rotation > 0 && noise.device_translation > 0 && noise.marker_rotation > 0 &&
              noise.marker_translation > 0 && noise.marker_depth >= 0,
          "noise", "all standard deviations must be > 0");
  require(!estimate_covariance || refine, "estimate_covariance", "needs refine = true");
}

Registration headset_registration(const SE3& vr_from_headset, const SE3& camera_from_board) {
  // vr_from_headset * headset_from_camera * camera_from_board = vr_from_board: the "marker"
  // is the camera and the measured "camera_from_marker" is board_from_camera.
  return Registration{vr_from_headset, camera_from_board.inverse()};
}

Summary solve(std::span<const Registration> registrations, const Options& options) {
  options.check();
  const int n = static_cast<int>(registrations.size());
  for (int k = 0; k < n; ++k) {
    if (!finite(registrations[k].vr_from_device) || !finite(registrations[k].camera_from_marker)) {
      throw Error("registration " + std::to_string(k) + " holds a non-finite pose",
                  {.field = "registrations"});
    }
  }
  if (n < 3) throw_degenerate(LinearStatus::kTooFewRegistrations, options, {});

  Summary summary;
  std::vector<bool> used(n, true);
  bool ransac_failed = false;
  if (options.robust) {
    used = ransac(registrations, options);
    if (used.empty()) throw_degenerate(LinearStatus::kSingleAxis, options, {});
    if (std::count(used.begin(), used.end(), true) < 3) {
      summary.message = "RANSAC found fewer than 3 consistent registrations";
      used.assign(n, true);  // fall back to all, flagged unusable below
      ransac_failed = true;
    }
  }
  Estimate estimate;
  const LinearStatus status =
      solve_subset(registrations, used, options, summary.conditioning, estimate);
  if (status != LinearStatus::kOk) throw_degenerate(status, options, summary.conditioning);

  bool refine_ok = true;
  summary.noise = options.noise;
  if (options.refine) {
    // The covariance is computed in the last round only.
    const int used_count = static_cast<int>(std::count(used.begin(), used.end(), true));
    const int rounds = used_count >= 6 ? options.noise_estimation_rounds : 0;
    Options round = options;
    round.estimate_covariance = options.estimate_covariance && rounds == 0;
    RefineResult refined = refine(registrations, used, estimate.device_from_marker,
                                  estimate.vr_from_camera, estimate.sigma, round);
    for (int k = 0; k < rounds && refined.converged; ++k) {
      round.noise = noise_from_residuals(registrations, used, refined.device_from_marker,
                                         refined.vr_from_camera, refined.sigma,
                                         12 + (options.estimate_scale ? 1 : 0));
      round.estimate_covariance = options.estimate_covariance && k + 1 == rounds;
      refined = refine(registrations, used, refined.device_from_marker, refined.vr_from_camera,
                       refined.sigma, round);
    }
    summary.noise = round.noise;
    refine_ok = refined.converged && refined.sigma > 0;
    summary.refined = refine_ok;
    summary.refine_iterations = refined.iterations;
    if (refine_ok) {
      estimate = {refined.device_from_marker, refined.vr_from_camera, refined.sigma};
      summary.device_from_marker_covariance = refined.device_from_marker_covariance;
      if (refined.sigma_variance) summary.sigma_stddev = std::sqrt(*refined.sigma_variance);
    } else {
      summary.message = "nonlinear refinement did not converge; linear solution kept";
    }
  }
  if (summary.device_from_marker_covariance) {
    const Matrix6d& c = *summary.device_from_marker_covariance;
    summary.translation_stddev = std::sqrt(c.topLeftCorner<3, 3>().trace());
    summary.rotation_stddev = std::sqrt(c.bottomRightCorner<3, 3>().trace());
  }
  summary.device_from_marker = estimate.device_from_marker;
  summary.vr_from_camera = estimate.vr_from_camera;
  summary.sigma = estimate.sigma;
  summary.scale_estimated = options.estimate_scale;
  summary.used = used;
  summary.num_used = static_cast<int>(std::count(used.begin(), used.end(), true));
  summary.residuals = compute_residuals(registrations, used, estimate);
  const bool enough_inliers =
      !options.robust || summary.num_used >= options.ransac.min_inlier_fraction * n;
  if (!enough_inliers && summary.message.empty()) {
    summary.message = "only " + std::to_string(summary.num_used) + " of " + std::to_string(n) +
                      " registrations are consistent";
  }
  summary.usable = summary.num_used >= 3 && enough_inliers && refine_ok && !ransac_failed;
  return summary;
}

}  // namespace coloc::registration::handeye
