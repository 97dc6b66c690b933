#pragma once
// Small fixtures of the session tests: calibration files and session descriptions written to a
// temporary folder, and a bounded wait.

#include <chrono>
#include <filesystem>
#include <functional>
#include <string>
#include <thread>

#include "fusion/session/config.hpp"
#include "slam/core/se3.hpp"

namespace coloc::fusion::session::testing {

// Writes a calibration file as `coloc handeye solve --output` does.
void write_calibration(const std::filesystem::path& path, const SE3& vr_from_camera,
                       const SE3& device_from_marker = SE3());

// A fixed-anchor session of the given participants (id, calibration file name, port), written
// to dir/session.yaml and read back.
SessionConfig two_user_config(const std::filesystem::path& dir, const SE3& world_from_camera,
                              const SE3& vr_a_from_camera, const SE3& vr_b_from_camera,
                              int port_a = 0);

SE3 pose(double yaw, const Eigen::Vector3d& t);  // rotation about z (rad), translation (m)

// A wait for something bound to happen (a datagram on loopback, the node's thread at work):
// only a stuck run reaches it, never a slow one (CI runs the suite on a busy 2-core machine).
constexpr int kArrivalMs = 60000;

// Waits (bounded) until condition() holds; polls every 2 ms (tests only).
bool wait_for(const std::function<bool()>& condition, int timeout_ms = kArrivalMs);

}  // namespace coloc::fusion::session::testing
