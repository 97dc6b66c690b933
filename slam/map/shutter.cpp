#include "slam/map/shutter.hpp"

#include "slam/core/so3.hpp"

namespace coloc::slam::map {
namespace {

// Turns point `p`, seen at keypoint `i` of its reference keyframe's frame `f`, as that keypoint's
// bearing turns when the compensation grows by `seconds` of readout at the recorded rate
// (exp(shear * seconds), frame/rolling_shutter.cpp); its depth (z, as the keyframe's u_right has
// it) stays. Call before `f` changes.
void turn_with_keypoint(MapPoint& p, const frame::Frame& f, std::uint32_t i, double seconds) {
  if (seconds == 0.0 || f.shutter_rate.isZero()) return;
  const Eigen::Vector3d before = f.cam_from_world * p.position;
  const Eigen::Vector3d turned = SO3::exp(f.shutter_shear(i) * seconds) * before;
  if (turned.z() <= 1e-9) return;
  p.position = f.cam_from_world.inverse() * (turned * (before.z() / turned.z()));
}

}  // namespace

void set_map_readout(Map& map, double readout) {
  bool stale = false;
  for (const auto& [id, kf] : map.keyframes())
    stale = stale || (kf.frame.shutter_readout != readout && !kf.frame.shutter_rate.isZero());
  if (!stale) return;
  // Points first: they need each reference keyframe's compensation before it changes.
  map.for_each_point([&](MapPoint& p) {
    const Keyframe* kf = map.keyframe(p.reference);
    const auto obs = p.observations.find(p.reference);
    if (kf && obs != p.observations.end())
      turn_with_keypoint(p, kf->frame, obs->second, readout - kf->frame.shutter_readout);
  });
  map.for_each_keyframe([&](Keyframe& kf) { kf.frame.set_shutter_readout(readout); });
}

void set_keyframe_shutter_rate(Map& map, KeyframeId id, const Eigen::Vector3d& rate_cam,
                               int image_rows, double readout) {
  Keyframe* kf = map.keyframe(id);
  if (!kf || !kf->frame.shutter_rate.isZero() || rate_cam.isZero()) return;
  // Recorded at readout 0 first (no keypoint moves): the points then turn with the shear of
  // that rate, as for a readout change from 0.
  kf->frame.compensate_rolling_shutter(rate_cam, image_rows, 0.0);
  const frame::Frame& f = kf->frame;
  for (std::size_t i = 0; i < f.size(); ++i) {
    MapPoint* p = f.points[i].valid() ? map.point(f.points[i]) : nullptr;
    if (p && p->reference == id) turn_with_keypoint(*p, f, static_cast<std::uint32_t>(i), readout);
  }
  kf->frame.set_shutter_readout(readout);
}

}  // namespace coloc::slam::map
