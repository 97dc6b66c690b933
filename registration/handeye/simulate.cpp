#include "registration/handeye/simulate.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <random>

#include "slam/core/error.hpp"

namespace coloc::registration::handeye {

namespace {

using Rng = std::mt19937_64;

Eigen::Vector3d random_unit(Rng& rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::Vector3d v;
  do
    v = Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
  while (v.norm() < 1e-9);
  return v.normalized();
}

Eigen::Vector3d gaussian(Rng& rng, double sigma) {
  std::normal_distribution<double> normal(0.0, sigma);
  return {normal(rng), normal(rng), normal(rng)};
}

SE3 add_noise(const SE3& pose, double rotation_sigma, double translation_sigma, Rng& rng) {
  const SO3 rotation = pose.so3() * SO3::exp(gaussian(rng, rotation_sigma));
  return SE3(rotation, pose.translation() + gaussian(rng, translation_sigma));
}

// Rotation whose columns are the camera axes: z towards `target`, x horizontal, y down.
SO3 look_at(const Eigen::Vector3d& from, const Eigen::Vector3d& target) {
  const Eigen::Vector3d z = (target - from).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  Eigen::Matrix3d r;
  r << x, z.cross(x), z;
  return SO3::from_matrix(r);
}

// world_from_marker with the marker's z axis (out of its face) tilted away from `to_camera`.
SO3 marker_orientation(const Eigen::Vector3d& to_camera, double max_tilt, double max_spin,
                       Rng& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Eigen::Vector3d tilt_axis = to_camera.cross(random_unit(rng));
  if (tilt_axis.norm() < 1e-6) tilt_axis = to_camera.unitOrthogonal();
  const Eigen::Vector3d normal =
      SO3::from_axis_angle(tilt_axis, max_tilt * std::sqrt(unit(rng))) * to_camera;
  const Eigen::Vector3d x0 = normal.unitOrthogonal();
  Eigen::Matrix3d r;
  r << x0, normal.cross(x0), normal;
  const double spin = max_spin * (2.0 * unit(rng) - 1.0);
  return SO3::from_matrix(r) * SO3::exp(Eigen::Vector3d(0, 0, spin));
}

SE3 gross_error(const SE3& pose, const SimulationOptions& options, Rng& rng) {
  std::uniform_real_distribution<double> factor(1.0, 3.0);
  const SO3 rotation =
      SO3::from_axis_angle(random_unit(rng), factor(rng) * options.outlier_rotation) * pose.so3();
  const Eigen::Vector3d shift = random_unit(rng) * factor(rng) * options.outlier_translation;
  return SE3(rotation, pose.translation() + shift);
}

void require(bool condition, const char* field, const char* what) {
  if (!condition) {
    throw Error(std::string("simulation option ") + field + ": " + what, {.field = field});
  }
}

}  // namespace

void SimulationOptions::check() const {
  require(num_registrations >= 1, "num_registrations", "must be >= 1");
  require(device_rotation_noise >= 0 && device_translation_noise >= 0 &&
              marker_rotation_noise >= 0 && marker_translation_noise >= 0,
          "noise", "standard deviations must be >= 0");
  require(outlier_fraction >= 0 && outlier_fraction <= 1, "outlier_fraction", "must be in [0, 1]");
  require(scale > 0, "scale", "must be > 0");
  require(camera_distance > workspace_radius, "camera_distance", "must exceed workspace_radius");
  require(max_tilt >= 0 && max_tilt < 1.5, "max_tilt", "must be in [0, 1.5) rad");
  require(max_spin >= 0 && max_spin <= std::numbers::pi, "max_spin", "must be in [0, pi] rad");
  require(marker_depth_noise >= 0, "marker_depth_noise", "must be >= 0");
}

Simulation simulate(const SimulationOptions& options) {
  options.check();
  Rng rng(options.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Simulation sim;
  sim.scale = options.scale;

  const Eigen::Vector3d centre(0.0, 0.0, 1.0);
  const Eigen::Vector3d camera_position(0.0, -options.camera_distance, 1.3);
  sim.world_from_camera = SE3(look_at(camera_position, centre), camera_position);
  const double yaw = std::numbers::pi * (2.0 * unit(rng) - 1.0);
  sim.world_from_vr = SE3(SO3::exp(Eigen::Vector3d(0, 0, yaw)),
                          Eigen::Vector3d(4.0 * unit(rng) - 2.0, 4.0 * unit(rng) - 2.0, 0.0));
  sim.device_from_marker = SE3(SO3::exp(random_unit(rng) * std::numbers::pi * unit(rng)),
                               random_unit(rng) * options.marker_offset);
  sim.vr_from_camera = sim.world_from_vr.inverse() * sim.world_from_camera;

  const SE3 marker_from_device = sim.device_from_marker.inverse();
  const SE3 camera_from_world = sim.world_from_camera.inverse();
  const SE3 vr_from_world = sim.world_from_vr.inverse();
  for (int i = 0; i < options.num_registrations; ++i) {
    Eigen::Vector3d offset;
    do
      offset = Eigen::Vector3d(2 * unit(rng) - 1, 2 * unit(rng) - 1, 2 * unit(rng) - 1);
    while (offset.norm() > 1.0);
    const Eigen::Vector3d position = centre + options.workspace_radius * offset;
    const SO3 rotation = marker_orientation((camera_position - position).normalized(),
                                            options.max_tilt, options.max_spin, rng);
    const SE3 world_from_device = SE3(rotation, position) * marker_from_device;
    sim.world_from_device.push_back(world_from_device);
    Registration r;
    r.vr_from_device = add_noise(vr_from_world * world_from_device, options.device_rotation_noise,
                                 options.device_translation_noise, rng);
    r.camera_from_marker =
        add_noise(camera_from_world * world_from_device * sim.device_from_marker,
                  options.marker_rotation_noise, options.marker_translation_noise, rng);
    if (options.marker_depth_noise > 0) {
      std::normal_distribution<double> depth(0.0, options.marker_depth_noise);
      const Eigen::Vector3d ray = r.camera_from_marker.translation().normalized();
      r.camera_from_marker.translation() += depth(rng) * ray;
    }
    sim.registrations.push_back(r);
  }

  const int n = options.num_registrations;
  sim.is_outlier.assign(n, false);
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), rng);
  const int outliers = static_cast<int>(std::lround(options.outlier_fraction * n));
  for (int k = 0; k < outliers; ++k) {
    const int i = order[k];
    sim.is_outlier[i] = true;
    Registration& r = sim.registrations[i];
    if (k % 2 == 0) {
      r.vr_from_device = gross_error(r.vr_from_device, options, rng);
    } else {
      r.camera_from_marker = gross_error(r.camera_from_marker, options, rng);
    }
  }
  for (Registration& r : sim.registrations) {
    r.camera_from_marker.translation() /= options.scale;
  }
  return sim;
}

NoiseModel noise_model(const SimulationOptions& options) {
  NoiseModel m;
  m.device_rotation = std::max(options.device_rotation_noise, 1e-9);
  m.device_translation = std::max(options.device_translation_noise, 1e-9);
  m.marker_rotation = std::max(options.marker_rotation_noise, 1e-9);
  m.marker_translation = std::max(options.marker_translation_noise, 1e-9);
  m.marker_depth = options.marker_depth_noise;
  return m;
}

PoseError pose_error(const SE3& estimate, const SE3& truth) {
  return {angular_distance(estimate.so3(), truth.so3()),
          (estimate.translation() - truth.translation()).norm()};
}

}  // namespace coloc::registration::handeye
