#pragma once
// The IMU in the global BA, through the map: a recording stores what its log measured at its
// keyframes (gravity windows, gyro links: map/inertial.hpp), and the BA takes its inertial terms
// from what every keyframe stores. A continued map thus holds the keyframes of earlier
// recordings by their own IMU, measured when their log was at hand, and each recording keeps
// biases of its own.
#include <vector>

#include "slam/map/map.hpp"
#include "slam/mapping/gravity.hpp"
#include "slam/mapping/gyro.hpp"
#include "slam/optim/bundle_adjustment.hpp"

namespace coloc::slam::mapping {

// What an IMU beside the camera measured during one recording; either may be null.
struct InertialMeasurements {
  const GravityMeasurements* gravity = nullptr;  // the keyframes' tilt
  const GyroMeasurements* gyro = nullptr;        // rotations between consecutive keyframes
  // The log's recording made the keyframes from this id on (ids are issued in creation order).
  // A continued map's loaded keyframes belong to another recording, whose clock this log must
  // not be read at: they keep what their own recording stored.
  KeyframeId first_keyframe{0};
};

// Stores in the map what `imu` measured at the keyframes from imu.first_keyframe on, in place of
// what they held: a gravity window each, and a link from each to the next in time. Links of
// earlier keyframes into them are dropped (another recording's clock). Needs the map lock.
void record_inertial(map::Map& map, const InertialMeasurements& imu);

// The noise models of the BA's inertial terms: the log's, or the defaults when only stored
// measurements are at hand.
struct InertialModels {
  optim::BundleProblem::GravityModel gravity;
  optim::BundleProblem::GyroModel gyro;
  static InertialModels of(const InertialMeasurements& imu);
};

// Adds to `problem` (whose poses are the keyframes `pose_ids`) the gravity windows and gyro
// links those keyframes store; a link to a keyframe outside the problem is left out. Biases are
// per recording: the oldest recording's accelerometer bias has index 0.
void add_inertial_terms(const map::Map& map, const std::vector<KeyframeId>& pose_ids,
                        const InertialModels& models, optim::BundleProblem& problem);

}  // namespace coloc::slam::mapping
