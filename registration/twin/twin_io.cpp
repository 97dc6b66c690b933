#include "registration/twin/twin_io.hpp"

#include <cstdio>
#include <fstream>

#include "slam/core/atomic_file.hpp"
#include "slam/core/error.hpp"

namespace coloc::registration::twin::io {
namespace {

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), f, v);
  return buf;
}

void matrix_yaml(std::ostream& out, const std::string& key, const Eigen::Matrix4d& m) {
  out << key << ": !!opencv-matrix\n   rows: 4\n   cols: 4\n   dt: f\n   data: [";
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) {
      out << fmt("%.9f", m(r, c)) << (r == 3 && c == 3 ? "]\n" : ", ");
    }
  }
}

}  // namespace

std::string tum_line(double t, const SE3& pose) {
  const Eigen::Quaterniond& q = pose.quaternion();
  const Eigen::Vector3d& p = pose.translation();
  char buf[256];
  std::snprintf(buf, sizeof(buf), "%.6f %.9f %.9f %.9f %.9f %.9f %.9f %.9f", t, p.x(), p.y(), p.z(),
                q.x(), q.y(), q.z(), q.w());
  return buf;
}

void write_camera_settings(const std::filesystem::path& path, const PinholeCamera& c, double fps,
                           const DepthNoiseOptions& depth, const ImuOptions& imu, int marker_dictionary,
                           double marker_size) {
  AtomicOutput out(path);
  out.precision(10);
  out << "%YAML:1.0\n\n# coloc digital twin: RGB-D camera (D455-like), ORB-SLAM3 v1.0 format.\n"
      << "File.version: \"1.0\"\n\nCamera.type: \"PinHole\"\n\n"
      << "Camera1.fx: " << fmt("%.6f", c.fx) << "\nCamera1.fy: " << fmt("%.6f", c.fy)
      << "\nCamera1.cx: " << fmt("%.6f", c.cx) << "\nCamera1.cy: " << fmt("%.6f", c.cy) << "\n\n"
      << "Camera1.k1: " << fmt("%.9f", c.distortion[0])
      << "\nCamera1.k2: " << fmt("%.9f", c.distortion[1])
      << "\nCamera1.p1: " << fmt("%.9f", c.distortion[2])
      << "\nCamera1.p2: " << fmt("%.9f", c.distortion[3])
      << "\nCamera1.k3: " << fmt("%.9f", c.distortion[4]) << "\n\n"
      << "Camera.width: " << c.width << "\nCamera.height: " << c.height << "\n\n"
      << "Camera.fps: " << static_cast<int>(std::lround(fps)) << "\n\nCamera.RGB: 1\n\n"
      << "# coloc: rendered with a global shutter (no rolling-shutter readout to estimate).\n"
      << "Camera.readoutTime: 0\n\n"
      << "# Close/Far threshold. Baseline times.\nStereo.ThDepth: 40.0\nStereo.b: "
      << fmt("%.4f", depth.baseline) << "\n\n# Depth map values factor (millimetres)\n"
      << "RGBD.DepthMapFactor: 1000.0\n\n"
      << "# IMU: T_b_c1 maps camera points into the IMU (body) frame.\n";
  matrix_yaml(out, "IMU.T_b_c1", imu.imu_from_cam.matrix());
  out << "IMU.InsertKFsWhenLost: 0\n"
      << "IMU.NoiseGyro: " << fmt("%.6e", imu.gyro_noise_density) << "\n"
      << "IMU.NoiseAcc: " << fmt("%.6e", imu.accel_noise_density) << "\n"
      << "IMU.GyroWalk: " << fmt("%.6e", imu.gyro_random_walk) << "\n"
      << "IMU.AccWalk: " << fmt("%.6e", imu.accel_random_walk) << "\n"
      << "IMU.Frequency: " << fmt("%.1f", imu.rate) << "\n\n"
      << "ORBextractor.nFeatures: 1000\nORBextractor.scaleFactor: 1.2\nORBextractor.nLevels: 8\n"
      << "ORBextractor.iniThFAST: 20\nORBextractor.minThFAST: 7\n\n"
      << "Markers.dictionary: \"" << marker_dictionary << "\"\n"
      << "Markers.size: " << fmt("%.4f", marker_size) << "\n";
  if (!out) throw Error("write failed", {.file = path.string()});
  out.commit();
}

void write_imu(const std::filesystem::path& path, const std::vector<ImuSample>& samples) {
  AtomicOutput out(path);
  out.precision(10);
  out << "# timestamp[s] gx gy gz [rad/s] ax ay az [m/s^2], IMU frame (see camera.yaml "
         "IMU.T_b_c1)\n";
  char buf[256];
  for (const ImuSample& s : samples) {
    std::snprintf(buf, sizeof(buf), "%.6f %.9f %.9f %.9f %.9f %.9f %.9f\n", s.timestamp, s.gyro.x(),
                  s.gyro.y(), s.gyro.z(), s.accel.x(), s.accel.y(), s.accel.z());
    out << buf;
  }
  if (!out) throw Error("write failed", {.file = path.string()});
  out.commit();
}

void write_imu_truth(const std::filesystem::path& path, const std::vector<ImuTruth>& truth) {
  AtomicOutput out(path);
  out.precision(10);
  out << "# timestamp[s] gx gy gz ax ay az (noise- and bias-free) bgx bgy bgz bax bay baz\n";
  char buf[512];
  for (const ImuTruth& t : truth) {
    const ImuSample& s = t.ideal;
    std::snprintf(buf, sizeof(buf),
                  "%.6f %.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", s.timestamp,
                  s.gyro.x(), s.gyro.y(), s.gyro.z(), s.accel.x(), s.accel.y(), s.accel.z(),
                  t.gyro_bias.x(), t.gyro_bias.y(), t.gyro_bias.z(), t.accel_bias.x(),
                  t.accel_bias.y(), t.accel_bias.z());
    out << buf;
  }
  if (!out) throw Error("write failed", {.file = path.string()});
  out.commit();
}

void write_headset_calibration(const std::filesystem::path& path, const HeadsetOptions& o,
                               const SE3& world_from_xr_start) {
  AtomicOutput out(path);
  out.precision(10);
  out << "%YAML:1.0\n# coloc digital twin: headset rigidly mounted with the RGB-D camera.\n"
      << "# cam_from_headset maps headset-frame points into the camera frame (the true X).\n";
  matrix_yaml(out, "cam_from_headset", o.cam_from_headset.matrix());
  out << "# world_from_xr at the first headset sample (the xr origin then drifts; see "
         "xr_drift.txt).\n";
  matrix_yaml(out, "world_from_xr_start", world_from_xr_start.matrix());
  out << "rate: " << fmt("%.1f", o.rate)
      << "\ntranslation_drift: " << fmt("%.6f", o.translation_drift)
      << "\nyaw_drift: " << fmt("%.6f", o.yaw_drift) << "\njitter: " << fmt("%.6f", o.jitter)
      << "\n";
  out.commit();
}

void write_markers(const std::filesystem::path& corners_path,
                   const std::filesystem::path& poses_path, const std::vector<MarkerTruth>& markers,
                   int dictionary) {
  AtomicOutput out(corners_path);
  AtomicOutput poses(poses_path);
  out.precision(10);
  poses.precision(10);
  out << "# dictionary " << dictionary
      << " (OpenCV predefined id). id size_m then 4 corners x y z in the scan (world) frame,\n"
         "# OpenCV order: top-left, top-right, bottom-right, bottom-left seen from the front\n";
  char buf[512];
  for (const MarkerTruth& m : markers) {
    out << m.id << ' ' << fmt("%.6f", m.size);
    for (const auto& c : m.corners) {
      std::snprintf(buf, sizeof(buf), " %.9f %.9f %.9f", c.x(), c.y(), c.z());
      out << buf;
    }
    out << '\n';
  }
  poses << "# id tx ty tz qx qy qz qw: world_from_marker (marker x right, y up, z out of the "
           "wall)\n";
  for (const MarkerTruth& m : markers) {
    const std::string line = tum_line(0.0, m.world_from_marker);
    poses << m.id << line.substr(line.find(' ')) << '\n';
  }
  out.commit();
  poses.commit();
}

void write_stations(const std::filesystem::path& stations_path,
                    const std::filesystem::path& faces_path,
                    const std::vector<ScanStation>& stations) {
  AtomicOutput out(stations_path);
  AtomicOutput faces(faces_path);
  out.precision(10);
  faces.precision(10);
  out << "# station tx ty tz qx qy qz qw: world_from_station (z up)\n";
  faces << "# station face width height fx fy cx cy tx ty tz qx qy qz qw: world_from_face "
           "(camera x right, y down, z forward; pixel centres at integers)\n";
  for (const ScanStation& s : stations) {
    std::string line = tum_line(0.0, s.world_from_station);
    out << s.index << line.substr(line.find(' ')) << '\n';
    const PinholeCamera& c = s.face_camera;
    for (std::size_t f = 0; f < 6; ++f) {
      line = tum_line(0.0, s.world_from_face[f]);
      faces << s.index << ' ' << f << ' ' << c.width << ' ' << c.height << ' ' << fmt("%.6f", c.fx)
            << ' ' << fmt("%.6f", c.fy) << ' ' << fmt("%.6f", c.cx) << ' ' << fmt("%.6f", c.cy)
            << line.substr(line.find(' ')) << '\n';
    }
  }
  out.commit();
  faces.commit();
}

}  // namespace coloc::registration::twin::io
