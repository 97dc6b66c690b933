#include "fusion/imu.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>

#include "slam/core/error.hpp"
#include "slam/core/input_file.hpp"

namespace coloc::fusion {

std::vector<ImuSample> read_imu_csv(const std::filesystem::path& path) {
  check_input_file(path, "IMU log");
  std::ifstream in(path);
  if (!in) throw Error("cannot open the IMU log", ErrorContext{.file = path.string()});
  std::vector<ImuSample> samples;
  std::string line;
  std::int64_t number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty() || line[0] == '#' || line == "\r") continue;
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream fields(line);
    double nanoseconds = 0.0;
    ImuSample s;
    if (!(fields >> nanoseconds >> s.gyro.x() >> s.gyro.y() >> s.gyro.z() >> s.accel.x() >>
          s.accel.y() >> s.accel.z()) ||
        !s.gyro.allFinite() || !s.accel.allFinite()) {
      throw Error("expected 't[ns],wx,wy,wz,ax,ay,az'",
                  ErrorContext{.file = path.string(), .line = number});
    }
    s.time = nanoseconds * 1e-9;
    if (!samples.empty() && !(s.time > samples.back().time)) {
      throw Error("timestamps must increase", ErrorContext{.file = path.string(), .line = number});
    }
    samples.push_back(s);
  }
  return samples;
}

std::optional<ImuState> initialize_static(std::span<const ImuSample> samples,
                                          const Eigen::Vector3d& gravity) {
  if (samples.size() < 2) return std::nullopt;
  Eigen::Vector3d gyro = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel = Eigen::Vector3d::Zero();
  for (const ImuSample& s : samples) {
    gyro += s.gyro;
    accel += s.accel;
  }
  gyro /= static_cast<double>(samples.size());
  accel /= static_cast<double>(samples.size());
  // Standard deviation, not the range: a hovering or idling platform vibrates (EuRoC's MAV on
  // the ground with rotors on: gyro peaks of 0.16 rad/s, standard deviation ~0.08 rad/s).
  double variance = 0.0;
  for (const ImuSample& s : samples)
    variance += (s.gyro - gyro).squaredNorm();
  variance /= static_cast<double>(samples.size());
  if (std::abs(accel.norm() - gravity.norm()) > 0.5 || variance > 0.1 * 0.1) return std::nullopt;

  // At rest the accelerometer reads -gravity in the body frame: R * accel = -gravity.
  const Eigen::Quaterniond q =
      Eigen::Quaterniond::FromTwoVectors(accel.normalized(), (-gravity).normalized());
  // FromTwoVectors may add yaw; remove it so the odom frame's heading starts at zero.
  const SO3 tilted(q);
  const Eigen::Vector3d forward = tilted * Eigen::Vector3d::UnitX();
  const double yaw = std::atan2(forward.y(), forward.x());
  ImuState state;
  state.time = samples.back().time;
  state.odom_from_body = SO3::from_axis_angle((-gravity).normalized(), -yaw) * tilted;
  state.gyro_bias = gyro;
  return state;
}

ImuState propagate(const ImuState& state, const ImuSample& a, const ImuSample& b,
                   const Eigen::Vector3d& gravity) {
  const double dt = b.time - a.time;
  ImuState next = state;
  next.time = b.time;
  const Eigen::Vector3d omega = 0.5 * (a.gyro + b.gyro) - state.gyro_bias;
  next.odom_from_body = state.odom_from_body * SO3::exp(omega * dt);
  // Specific force rotated with the rotation at each end, averaged (midpoint rule).
  const Eigen::Vector3d acc_a = state.odom_from_body * (a.accel - state.accel_bias);
  const Eigen::Vector3d acc_b = next.odom_from_body * (b.accel - state.accel_bias);
  const Eigen::Vector3d acceleration = 0.5 * (acc_a + acc_b) + gravity;
  next.position = state.position + state.velocity * dt + 0.5 * acceleration * dt * dt;
  next.velocity = state.velocity + acceleration * dt;
  return next;
}

void ImuFuserOptions::check() const {
  fuser.check();
  const auto require = [](bool ok, const char* field) {
    if (!ok) {
      throw Error("out of range", ErrorContext{.field = std::string("ImuFuserOptions.") + field});
    }
  };
  require(gravity.norm() > 1.0, "gravity");
  require(static_init_seconds > 0.0, "static_init_seconds");
  require(position_bandwidth >= 0.0 && position_bandwidth < 10.0, "position_bandwidth");
  require(rotation_bandwidth >= 0.0 && rotation_bandwidth < 10.0, "rotation_bandwidth");
  require(max_gap > 0.0, "max_gap");
}

ImuFuser::ImuFuser(ImuFuserOptions options)
    : options_(std::move(options)), fuser_(options_.fuser), gravity_(options_.gravity) {
  options_.check();
}

void ImuFuser::initialize(const ImuState& state, bool in_world) {
  state_ = state;
  initialized_ = true;
  anchored_ = in_world;
  last_correction_ = state.time;
  init_samples_.clear();
  integrated_.clear();
}

FusedPose ImuFuser::push_imu(const ImuSample& sample) {
  if (have_last_ && !(sample.time > last_.time)) {
    ++stats_.out_of_order;
    return fuser_.latest();
  }
  ++stats_.imu_samples;
  const ImuSample previous = last_;
  const bool had_previous = have_last_;
  last_ = sample;
  have_last_ = true;

  if (!initialized_) {
    init_samples_.push_back(sample);
    if (sample.time - init_samples_.front().time < options_.static_init_seconds) {
      return fuser_.latest();
    }
    if (auto state = initialize_static(init_samples_, options_.gravity)) {
      initialize(*state);
    } else {
      init_samples_.erase(init_samples_.begin());  // keep waiting for a static window
      return fuser_.latest();
    }
  } else if (had_previous && sample.time > state_.time) {
    if (sample.time - previous.time > options_.max_gap) {
      ++stats_.gaps;
      state_.time = sample.time;  // do not integrate across the gap; the feedback absorbs it
    } else {
      state_ = propagate(state_, previous, sample, gravity_);
    }
  }
  integrated_.push(state_.time, state_.pose());
  if (!anchored_) return fuser_.latest();  // not in the world frame yet: nothing to output
  return fuser_.push_xr_pose(state_.time, state_.pose());
}

void ImuFuser::anchor(const SE3& world_from_odom) {
  // Move the whole integration into the world frame, gravity included.
  state_.odom_from_body = world_from_odom.so3() * state_.odom_from_body;
  state_.position = world_from_odom * state_.position;
  state_.velocity = world_from_odom.so3() * state_.velocity;
  gravity_ = world_from_odom.so3() * gravity_;
  integrated_.clear();
  integrated_.push(state_.time, state_.pose());
  fuser_ = DriftFuser(options_.fuser);
  anchored_ = true;
  last_correction_ = state_.time;
}

GateDecision ImuFuser::push_global_pose(double time, const SE3& world_from_body,
                                        TrackingState tracking) {
  const std::optional<SE3> integrated =
      initialized_ ? integrated_.at(time, options_.fuser.max_extrapolation) : std::nullopt;
  if (!anchored_) {
    if (!integrated || tracking == TrackingState::kLost || tracking == TrackingState::kOdometry)
      return GateDecision::kRejected;
    anchor(world_from_body * integrated->inverse());
    return GateDecision::kInitialized;
  }
  const GateDecision decision = fuser_.push_global_pose(time, world_from_body, tracking);
  if (decision != GateDecision::kRejected && integrated) {
    feed_back(time, world_from_body, *integrated);
  }
  return decision;
}

void ImuFuser::feed_back(double time, const SE3& world_from_body, const SE3& integrated) {
  // Errors at the exposure time, applied now: they change slowly compared with the latency.
  const double dt = std::clamp(time - last_correction_, 0.0, 0.2);
  last_correction_ = std::max(last_correction_, time);
  if (dt <= 0.0) return;
  ++stats_.corrections;
  const Eigen::Vector3d position_error = world_from_body.translation() - integrated.translation();
  const Eigen::Vector3d rotation_error = (world_from_body.so3() * integrated.so3().inverse()).log();
  const SO3 body_from_world = state_.odom_from_body.inverse();

  // Third-order loop with a triple pole at -w: gains 3w, 3w^2, w^3.
  const double w = options_.position_bandwidth;
  state_.position += 3.0 * w * dt * position_error;
  state_.velocity += 3.0 * w * w * dt * position_error;
  // Integrated acceleration too high along e means the accel bias estimate is too low.
  state_.accel_bias -= w * w * w * dt * (body_from_world * position_error);

  // Second-order loop with a double pole at -r: gains 2r, r^2. A gyro bias residual e turns the
  // integrated rotation by -R e per second in the world frame, hence the sign.
  const double r = options_.rotation_bandwidth;
  state_.odom_from_body = SO3::exp(2.0 * r * dt * rotation_error) * state_.odom_from_body;
  state_.gyro_bias -= r * r * dt * (body_from_world * rotation_error);
}

}  // namespace coloc::fusion
