#pragma once
// Levenberg-Marquardt for bundle problems made of reprojections only (poses, points and the
// optional rolling-shutter readout; no gravity, no gyro), with the points eliminated and the
// reduced camera system solved densely. This is the local BA's shape: a window of 5-30 free
// keyframes, all covisible, so the reduced system is small and nearly full. Ceres solved the
// same problems through its generic machinery: a 7-parameter pose block whose Jacobian is
// multiplied by the manifold's at every evaluation, a loss corrector per residual, and the
// Schur eliminator of unknown block sizes (`<-1,-1,-1>`: the window mixes 2-row and 3-row
// residuals), rebuilt for each of the two passes. Here the 6-column Jacobians are computed
// directly and every block size is known at compile time.
//
// The same cost and the same trust-region rule as Ceres' LM (bundle_adjustment.cpp): cost =
// 1/2 sum rho(|r|^2) + the readout's prior, Huber rho with the observation's chi2 threshold in
// the robust pass, damping mu * diag(J^T J) with the diagonal clamped to [1e-6, 1e32], mu
// starting at 1e-4 and updated by the gain ratio (Nielsen), the readout clamped to its bounds,
// and Ceres' stopping rules: a step that changes the cost by less than 1e-6 of it ends the solve
// without being taken (taking it moved every BA by 1e-5-1e-4 and fr1/rpy's median ATE by 2 mm).
// The Huber kernel is applied as a weight (IRLS), which is what Ceres' corrector reduces to for
// a kernel with rho'' <= 0: the two solvers give the same estimate to rounding.
#include <atomic>
#include <cstdint>
#include <vector>

#include "slam/optim/bundle_adjustment.hpp"

namespace coloc::slam::optim {

struct DenseSchurPass {
  bool robust = true;  // Huber kernel, threshold sqrt(chi2) per observation kind
  int iterations = 10;
  double chi2_stereo = 7.815, chi2_mono = 5.991;
};

struct DenseSchurStats {
  int iterations = 0;  // as Ceres counts them: the initial evaluation plus each step tried
  double initial_cost = 0.0, final_cost = 0.0;
  double build_ms = 0.0, evaluate_ms = 0.0, linear_solver_ms = 0.0;
};

// Whether dense_schur_solve can solve `problem`: no gravity windows, no gyro pairs.
bool dense_schur_applies(const BundleProblem& problem);

// Optimizes the free poses in `pose_params` (7 per pose, bundle_adjustment.hpp's layout), the
// points of `problem` and, when problem.readout.estimate, `readout_change` (seconds from
// problem.readout.current), over the observations not flagged in `skip`. Fixed poses are read,
// never written. `abort` (may be null) is polled before each step.
DenseSchurStats dense_schur_solve(BundleProblem& problem, std::vector<double>& pose_params,
                                  double& readout_change, const Intrinsics& k,
                                  const std::vector<std::uint8_t>& skip, const DenseSchurPass& pass,
                                  const std::atomic<bool>* abort);

}  // namespace coloc::slam::optim
