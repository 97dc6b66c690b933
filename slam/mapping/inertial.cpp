#include "slam/mapping/inertial.hpp"

#include <algorithm>
#include <map>
#include <unordered_map>
#include <utility>

namespace coloc::slam::mapping {

void record_inertial(map::Map& map, const InertialMeasurements& imu) {
  const KeyframeId first = imu.first_keyframe;
  std::vector<std::pair<double, KeyframeId>> by_time;
  map.for_each_keyframe([&](map::Keyframe& kf) {
    if (kf.id < first) {
      if (kf.gyro && kf.gyro->next >= first) kf.gyro.reset();
      return;
    }
    kf.gravity.reset();
    kf.gyro.reset();
    by_time.emplace_back(kf.frame.timestamp, kf.id);
    if (!imu.gravity) return;
    if (auto g = imu.gravity->at(kf.frame.timestamp))
      kf.gravity = map::GravityWindow{first, g->specific_force_cam, g->accel_world};
  });
  if (!imu.gyro) return;
  std::sort(by_time.begin(), by_time.end());
  for (std::size_t i = 1; i < by_time.size(); ++i) {
    const auto g = imu.gyro->between(by_time[i - 1].first, by_time[i].first);
    if (!g) continue;
    map.keyframe(by_time[i - 1].second)->gyro =
        map::GyroLink{first, by_time[i].second, g->cam_a_from_cam_b, g->bias_jacobian, g->dt};
  }
}

InertialModels InertialModels::of(const InertialMeasurements& imu) {
  InertialModels m;
  if (imu.gravity) m.gravity = imu.gravity->options().model;
  if (imu.gyro) m.gyro = imu.gyro->options().model;
  return m;
}

void add_inertial_terms(const map::Map& map, const std::vector<KeyframeId>& pose_ids,
                        const InertialModels& models, optim::BundleProblem& problem) {
  problem.gravity_model = models.gravity;
  problem.gyro_model = models.gyro;
  std::unordered_map<KeyframeId, std::uint32_t> pose_of;
  std::map<KeyframeId, std::uint32_t> bias_of;  // recording -> accelerometer bias, oldest first
  for (std::size_t i = 0; i < pose_ids.size(); ++i) {
    pose_of.emplace(pose_ids[i], static_cast<std::uint32_t>(i));
    const map::Keyframe& kf = *map.keyframe(pose_ids[i]);
    if (kf.gravity) bias_of.emplace(kf.gravity->recording, 0);
  }
  std::uint32_t n = 0;
  for (auto& [recording, index] : bias_of)
    index = n++;
  for (std::size_t i = 0; i < pose_ids.size(); ++i) {
    const map::Keyframe& kf = *map.keyframe(pose_ids[i]);
    const auto pose = static_cast<std::uint32_t>(i);
    if (kf.gravity)
      problem.gravity.push_back({pose, bias_of.at(kf.gravity->recording),
                                 kf.gravity->specific_force_cam, kf.gravity->accel_world});
    if (!kf.gyro) continue;
    const auto next = pose_of.find(kf.gyro->next);
    if (next == pose_of.end()) continue;
    problem.gyro.push_back(
        {pose, next->second, kf.gyro->cam_from_next, kf.gyro->bias_jacobian, kf.gyro->dt});
  }
}

}  // namespace coloc::slam::mapping
