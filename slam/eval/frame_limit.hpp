#pragma once
// The frame-to-frame limit of a sequence: how well can ANY global-shutter frame-to-frame tracker
// do on it? For each frame, the previous frame is placed at its ground-truth pose, its keypoints
// with depth become 3-D points, and the frame's pose is solved from descriptor matches with the
// tracker's own pose optimizer (Huber, chi2 rounds), starting from the truth. What remains is
// the error the data impose: motion blur, rolling shutter, colour/depth time offsets, depth
// noise, ground-truth noise. A SLAM result far above this limit leaves room for the method; one
// near it does not. With a rolling-shutter readout time, the keypoints are compensated with the
// ground-truth rotation rate first: scanning the readout shows the camera's (TUM fr1's Kinect:
// about 20 ms).
//
// Library coloc_eval_frame_limit (slam/eval): it needs the SLAM front end (features, frame,
// optim), which the trajectory metrics of coloc_eval do not.

#include <cstddef>
#include <functional>
#include <optional>
#include <vector>

#include "slam/core/timing.hpp"
#include "slam/dataset/sequence.hpp"
#include "slam/eval/trajectory_error.hpp"
#include "slam/settings/settings.hpp"

namespace coloc::eval {

struct FrameLimitOptions {
  double window_px = 120.0;  // match search radius, pixels (fast rotation moves ~50 px/frame)
  // Rolling-shutter readout, seconds (first to last row); unset: the settings' readoutTime;
  // 0: global-shutter model.
  std::optional<double> readout;
  double max_ratio = 0.8;             // Lowe's ratio test on descriptor distances
  std::size_t min_matches = 10;       // fewer matches: the pair is not solved
  double max_ground_truth_gap = 0.1;  // seconds between ground-truth samples to interpolate

  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

// One solved frame pair: frame `frame` against frame `frame - 1` placed at its ground truth.
struct FramePairError {
  std::size_t frame = 0;        // index in the sequence
  double timestamp = 0.0;       // seconds
  double rotation_deg = 0.0;    // angle of the pose error
  double translation_mm = 0.0;  // camera-centre error, millimetres
  std::size_t matches = 0;      // descriptor matches given to the optimizer
  int inliers = 0;              // pose-optimizer inliers
};

struct FrameLimitResult {
  double readout = 0.0;               // seconds, the readout model used
  std::vector<FramePairError> pairs;  // in frame order
  ErrorStats rotation_deg;            // over the pairs (rmse, median, max, ...)
  ErrorStats translation_mm;
  SampleStats inliers;

  // The n pairs with the largest translation error, largest first.
  std::vector<FramePairError> worst(std::size_t n) const;
};

// Called after each frame with (frames done, frames total), e.g. to draw a progress bar.
using FrameLimitProgress = std::function<void(std::size_t, std::size_t)>;

// Measures the limit over `sequence` (read with the settings' depth scale) with the camera,
// depth model and ORB parameters of `settings`. Throws coloc::Error (naming the sequence's
// folder or the settings file) when the sequence has no ground truth, the settings have no
// depth model, or no frame pair could be solved.
FrameLimitResult measure_frame_limit(const dataset::Sequence& sequence,
                                     const settings::Settings& settings,
                                     const FrameLimitOptions& options = {},
                                     const FrameLimitProgress& progress = {});

}  // namespace coloc::eval
