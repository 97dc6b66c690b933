#pragma once
// Descriptor matching guided by geometry (ORB-SLAM's ORBmatcher searches), over the id-keyed
// map. All functions read the map (the caller holds the map lock) and write matches into the
// frame's `points` (keypoint -> map point id); they return the number of new matches.
#include <vector>

#include "slam/bow/bow_vector.hpp"
#include "slam/frame/frame.hpp"
#include "slam/map/map.hpp"

namespace coloc::slam::matching {

constexpr int kDescriptorHigh = 100;  // ORB-SLAM's TH_HIGH (Hamming)
constexpr int kDescriptorLow = 50;    // TH_LOW

// Keeps the matches (keypoint indices into `keypoint_of`) whose orientation change falls in
// the three fullest of 30 bins; returns the indices to drop.
std::vector<std::size_t> rotation_outliers(const std::vector<float>& angle_change);

// Motion-model search: projects the points matched in `last` (inliers only) into `current`
// (whose cam_from_world is the prediction) within `radius_px` * scale of the last level.
int search_from_last_frame(frame::Frame& current, const frame::Frame& last, const map::Map& map,
                           double radius_px);

// Local-map search: projects `candidates` (points not yet matched in `frame`) into it with the
// frustum test (depth > 0, inside the image, distance in the scale range, viewing angle < 60
// degrees) and matches with a ratio test between pyramid levels. Returns the number of
// matches; `visible` receives the ids that passed the frustum test (the caller counts them in
// MapPoint::visible when it maintains the map; a localizer leaves the map untouched).
int search_local_points(frame::Frame& frame, const std::vector<MapPointId>& candidates,
                        const map::Map& map, double th, std::vector<MapPointId>* visible = nullptr);

// Projects the points of `keyframe` into `frame` (pose set), matching with a wide window;
// used after relocalization. Skips points already matched in `frame`.
int search_keyframe_points(frame::Frame& frame, const map::Keyframe& keyframe, const map::Map& map,
                           double radius_px, int max_distance);

// Matches between a keyframe's points and a frame's keypoints through the vocabulary's direct
// index: frame keypoint -> map point. Needs both feature vectors.
int search_by_bow(const map::Keyframe& keyframe, frame::Frame& frame, const map::Map& map);

}  // namespace coloc::slam::matching
