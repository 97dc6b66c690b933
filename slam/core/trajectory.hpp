#pragma once
// Trajectories in the TUM format: one pose per line, "t tx ty tz qx qy qz qw", where t is in
// seconds and the pose is world_from_cam (camera-to-world), as the TUM benchmark, evo and
// ORB-SLAM write them. Lines starting with '#' are comments.

#include <filesystem>
#include <vector>

#include "slam/core/se3.hpp"

namespace coloc {

struct StampedPose {
  double timestamp = 0.0;  // seconds
  SE3 world_from_cam;
};

using Trajectory = std::vector<StampedPose>;

// Throws coloc::Error naming the file and line for unreadable files or malformed lines.
Trajectory read_tum_trajectory(const std::filesystem::path& path);
// Writes with full precision (timestamps to 1e-6 s, 9 significant digits for poses). A pose
// with a NaN / inf (or a non-finite timestamp) is not written: in a TUM file a lost frame is a
// missing row. Returns how many were left out, for the caller to report.
std::size_t write_tum_trajectory(const std::filesystem::path& path, const Trajectory& trajectory);

// Pairs a[i] with the b pose nearest in time within max_dt seconds, each b used at most once
// (the greedy nearest-first matching of the TUM tools' associate.py). Result: index pairs.
std::vector<std::pair<std::size_t, std::size_t>> associate_by_time(const Trajectory& a,
                                                                   const Trajectory& b,
                                                                   double max_dt);

// Order-preserving association of two sorted streams (e.g. colour and depth frames): the
// largest set of pairs with |dt| <= max_dt such that i < i' implies j < j', and among those
// the one with the smallest total |dt|. Unlike the greedy matching, one slightly-off pair
// cannot knock its neighbours out (TUM fr1/xyz: 37 pairs instead of 32). O(P log P) in the
// number P of candidate pairs.
std::vector<std::pair<std::size_t, std::size_t>> associate_in_order(const std::vector<double>& a,
                                                                    const std::vector<double>& b,
                                                                    double max_dt);

}  // namespace coloc
