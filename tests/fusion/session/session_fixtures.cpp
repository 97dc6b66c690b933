#include "session_fixtures.hpp"

#include <fstream>
#include <sstream>

#include "registration/handeye/io.hpp"

namespace coloc::fusion::session::testing {
namespace {

std::string matrix_text(const SE3& pose) {
  const Eigen::Matrix4d m = pose.matrix();
  std::ostringstream s;
  s.precision(17);
  s << "[";
  for (int k = 0; k < 16; ++k)
    s << (k ? ", " : "") << m(k / 4, k % 4);
  s << "]";
  return s.str();
}

}  // namespace

void write_calibration(const std::filesystem::path& path, const SE3& vr_from_camera,
                       const SE3& device_from_marker) {
  registration::handeye::write_calibration(path, {device_from_marker, vr_from_camera, 1.0});
}

SessionConfig two_user_config(const std::filesystem::path& dir, const SE3& world_from_camera,
                              const SE3& vr_a_from_camera, const SE3& vr_b_from_camera,
                              int port_a) {
  write_calibration(dir / "a.yaml", vr_a_from_camera);
  write_calibration(dir / "b.yaml", vr_b_from_camera);
  std::ofstream out(dir / "session.yaml");
  out << "anchor:\n  camera: tripod\n  world_from_camera: " << matrix_text(world_from_camera)
      << "\nstale_after: 0.5\nparticipants:\n"
      << "  - {id: vive, kind: vr, system: HTC VIVE Pro, calibration: a.yaml"
      << (port_a > 0 ? ", port: " + std::to_string(port_a) : std::string()) << "}\n"
      << "  - {id: quest, kind: vr, system: Meta Quest 2, calibration: b.yaml}\n";
  out.close();
  return read_session_config(dir / "session.yaml");
}

SE3 pose(double yaw, const Eigen::Vector3d& t) {
  return SE3(Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ())), t);
}

bool wait_for(const std::function<bool()>& condition, int timeout_ms) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  while (std::chrono::steady_clock::now() < deadline) {
    if (condition()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return condition();
}

}  // namespace coloc::fusion::session::testing
