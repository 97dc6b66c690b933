#pragma once
// Moving a whole SLAM map into another frame: what rough alignment does to the map before the
// marker bundle adjustment starts from it.
#include "slam/core/sim3.hpp"
#include "slam/map/map.hpp"

namespace coloc::registration::align {

// Maps every point p to frame_from_slam * p and every keyframe pose so that the camera centre
// moves as a point and the orientation turns with the rotation: world_from_cam becomes
// (R * R_wc, s R t_wc + t). With a scale s != 1 the camera-frame lengths a map holds scale too:
// keypoint depths (and their virtual right coordinates), the keyframes' depth images and the
// erased keyframes' relative translations, so the map stays self-consistent.
void transform_map(slam::map::Map& map, const Sim3& frame_from_slam);

}  // namespace coloc::registration::align
