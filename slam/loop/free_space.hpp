#pragma once
// The free-space test of a loop (RGB-D): two views of one place agree on where its surfaces
// are, so each view's depth, placed in the other by the verified pose, lies on or behind the
// surfaces the other sees. A look-alike place (the same wall texture in another room, the same
// shelf in another aisle) matches where its features are and disagrees elsewhere: one view
// has a surface where the other looked through empty space to something farther. Appearance
// and the pose's reprojection errors cannot see that; the plausibility bound cannot either once
// the path is long enough to allow the look-alike's offset.
//
// The depth compared is the keyframes' stored small depth image (map::KeyframeDepth), so the
// test costs a few thousand projections per keyframe pair and needs no recording.
#include <algorithm>
#include <vector>

#include "slam/core/camera.hpp"
#include "slam/core/se3.hpp"
#include "slam/map/keyframe_depth.hpp"

namespace coloc::slam::loop {

struct FreeSpaceOptions {
  int stride = 2;                 // small pixels between the samples taken of a depth image
  double tolerance_m = 0.05;      // depths this close agree (metres) ...
  double tolerance_ratio = 0.03;  // ... plus this fraction of the depth (sensor noise grows)
  // A sample in the other view's free space is one nearer than every depth the other view
  // measured within this many small pixels of where it lands (by more than the tolerance):
  // a sample just beside a depth edge does not count against the loop.
  int edge_radius = 1;
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

struct FreeSpaceCount {
  int agree = 0;     // samples on the surface the other view sees
  int occluded = 0;  // behind it (no evidence either way)
  int violate = 0;   // in front of everything the other view measured there
  // The largest violation() of one keyframe pair (both ways) with at least kPairSamples
  // compared: logged beside the sum, which dilutes a look-alike's evidence over the pairs that
  // see only the shared walls (0 when no pair had enough samples).
  static constexpr int kPairSamples = 500;
  double worst_pair = 0.0;
  int compared() const { return agree + violate; }
  // Share of the compared samples that violate (0 when none was compared).
  double violation() const {
    return compared() > 0 ? static_cast<double>(violate) / compared() : 0.0;
  }
  FreeSpaceCount& operator+=(const FreeSpaceCount& o) {
    agree += o.agree;
    occluded += o.occluded;
    violate += o.violate;
    worst_pair = std::max(worst_pair, o.worst_pair);
    return *this;
  }
};

// A depth image's samples (every options.stride-th small pixel with depth) back-projected
// through `camera` into its camera frame: once per keyframe, since undoing lens distortion is the
// costly step and a keyframe is compared with many others.
std::vector<Eigen::Vector3d> depth_samples(const map::KeyframeDepth& depth, const Camera& camera,
                                           const FreeSpaceOptions& options);

// `from_samples` (depth_samples() of one view) moved into the other view by
// `to_cam_from_from_cam`, projected through `camera` and compared with that view's depth `to`.
// Both images come from frames of `camera` (the same sensor; the factor may differ).
FreeSpaceCount compare_depth(const std::vector<Eigen::Vector3d>& from_samples,
                             const map::KeyframeDepth& to, const SE3& to_cam_from_from_cam,
                             const Camera& camera, const FreeSpaceOptions& options);

}  // namespace coloc::slam::loop
