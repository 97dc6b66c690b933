#include "slam/mapping/readout.hpp"

#include "slam/core/so3.hpp"
#include "slam/frame/rolling_shutter.hpp"

namespace coloc::slam::mapping {

void set_map_readout(map::Map& map, double readout) {
  bool stale = false;
  for (const auto& [id, kf] : map.keyframes())
    stale = stale || (kf.frame.shutter_readout != readout && !kf.frame.shutter_rate.isZero());
  if (!stale) return;
  // Points first: they need each reference keyframe's compensation before it changes.
  map.for_each_point([&](map::MapPoint& p) {
    const map::Keyframe* kf = map.keyframe(p.reference);
    const auto obs = p.observations.find(p.reference);
    if (!kf || obs == p.observations.end()) return;
    const frame::Frame& f = kf->frame;
    const double change = readout - f.shutter_readout;
    if (change == 0.0 || f.shutter_rate.isZero()) return;
    // The keypoint's bearing turns by exp(shear * change) (frame/rolling_shutter.cpp); its
    // depth (z, as the keyframe's u_right has it) stays.
    const Eigen::Vector3d before = f.cam_from_world * p.position;
    const Eigen::Vector3d turned = SO3::exp(f.shutter_shear(obs->second) * change) * before;
    if (turned.z() <= 1e-9) return;
    p.position = f.cam_from_world.inverse() * (turned * (before.z() / turned.z()));
  });
  map.for_each_keyframe([&](map::Keyframe& kf) { kf.frame.set_shutter_readout(readout); });
}

}  // namespace coloc::slam::mapping
