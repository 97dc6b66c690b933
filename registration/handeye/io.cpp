#include "registration/handeye/io.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <string>

#include "slam/core/atomic_file.hpp"
#include "slam/core/error.hpp"
#include "slam/core/input_file.hpp"
#include "slam/core/rigid.hpp"
#include "slam/core/trajectory.hpp"

namespace coloc::registration::handeye {

namespace {

constexpr std::array<const char*, 7> kPoseFields = {"tx", "ty", "tz", "qx", "qy", "qz", "qw"};

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> fields;
  std::string current;
  for (char c : line) {
    if (c == ',' || c == ' ' || c == '\t' || c == '\r') {
      if (!current.empty()) fields.push_back(current);
      current.clear();
    } else {
      current += c;
    }
  }
  if (!current.empty()) fields.push_back(current);
  return fields;
}

bool parse_double(const std::string& text, double& value) {
  const char* end = text.data() + text.size();
  const auto result = std::from_chars(text.data(), end, value);
  return result.ec == std::errc() && result.ptr == end && std::isfinite(value);
}

struct Reader {
  std::filesystem::path path;
  int line = 0;

  [[noreturn]] void fail(const std::string& message, const std::string& field) const {
    throw Error(message, {.file = path.string(), .field = field, .line = line});
  }

  double number(const std::string& text, const std::string& field) const {
    double value = 0.0;
    if (!parse_double(text, value)) fail("not a number: '" + text + "'", field);
    return value;
  }

  // Seven fields from `first`: translation then quaternion (x, y, z, w).
  SE3 pose(const std::vector<std::string>& fields, std::size_t first,
           const std::string& prefix) const {
    std::array<double, 7> v{};
    for (std::size_t k = 0; k < 7; ++k)
      v[k] = number(fields[first + k], prefix + kPoseFields[k]);
    const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
    if (std::abs(q.norm() - 1.0) > 1e-2) {
      fail("quaternion is not unit (norm " + std::to_string(q.norm()) + ")", prefix + "q");
    }
    return SE3(q, Eigen::Vector3d(v[0], v[1], v[2]));
  }
};

// Calls on_fields(fields) for every data line with the expected field count.
template <typename Fn>
void read_lines(const std::filesystem::path& path, std::size_t count, Fn on_fields) {
  check_input_file(path, "pose file");
  std::ifstream in(path);
  if (!in) throw Error("cannot open file", {.file = path.string()});
  Reader reader{path, 0};
  std::string line;
  bool seen_data = false;
  while (std::getline(in, line)) {
    ++reader.line;
    const std::size_t hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    const std::vector<std::string> fields = split(line);
    if (fields.empty()) continue;
    double ignored = 0.0;
    if (!seen_data && !parse_double(fields[0], ignored)) continue;  // header line
    seen_data = true;
    if (fields.size() != count) {
      reader.fail(
          "expected " + std::to_string(count) + " fields, got " + std::to_string(fields.size()),
          "line");
    }
    on_fields(reader, fields);
  }
}

void write_pose(std::ostream& out, const SE3& pose) {
  const Eigen::Quaterniond& q = pose.quaternion();
  const Eigen::Vector3d& t = pose.translation();
  out << ',' << t.x() << ',' << t.y() << ',' << t.z() << ',' << q.x() << ',' << q.y() << ','
      << q.z() << ',' << q.w();
}

}  // namespace

std::vector<TimedPose> read_pose_csv(const std::filesystem::path& path) {
  std::vector<TimedPose> poses;
  read_lines(path, 8, [&](const Reader& reader, const std::vector<std::string>& fields) {
    poses.push_back({reader.number(fields[0], "t"), reader.pose(fields, 1, "")});
  });
  return poses;
}

void write_pose_csv(const std::filesystem::path& path, const std::vector<TimedPose>& poses) {
  AtomicOutput out(path);
  out << std::setprecision(12);
  out << "t,tx,ty,tz,qx,qy,qz,qw\n";
  for (const TimedPose& p : poses) {
    out << p.t;
    write_pose(out, p.pose);
    out << '\n';
  }
  out.commit();
}

std::vector<TimedRegistration> read_pairs_file(const std::filesystem::path& path) {
  std::vector<TimedRegistration> out;
  read_lines(path, 15, [&](const Reader& reader, const std::vector<std::string>& fields) {
    out.push_back({reader.number(fields[0], "t"),
                   {reader.pose(fields, 1, "device_"), reader.pose(fields, 8, "marker_")}});
  });
  return out;
}

void write_pairs_file(const std::filesystem::path& path,
                      const std::vector<TimedRegistration>& registrations) {
  AtomicOutput out(path);
  out << std::setprecision(12);
  out << "# t, vr_from_device tx ty tz qx qy qz qw, camera_from_marker tx ty tz qx qy qz qw\n";
  for (const TimedRegistration& r : registrations) {
    out << r.t;
    write_pose(out, r.registration.vr_from_device);
    write_pose(out, r.registration.camera_from_marker);
    out << '\n';
  }
  out.commit();
}

std::vector<TimedRegistration> match_by_time(const std::vector<TimedPose>& vr_from_device,
                                             const std::vector<TimedPose>& camera_from_marker,
                                             double max_dt) {
  // associate_by_time needs time-sorted input; files need not be.
  auto sorted = [](std::vector<TimedPose> poses) {
    std::stable_sort(poses.begin(), poses.end(),
                     [](const TimedPose& a, const TimedPose& b) { return a.t < b.t; });
    Trajectory out;
    for (const TimedPose& p : poses)
      out.push_back({p.t, p.pose});
    return out;
  };
  const Trajectory device = sorted(vr_from_device);
  const Trajectory marker = sorted(camera_from_marker);
  std::vector<TimedRegistration> out;
  for (const auto& [i, j] : associate_by_time(device, marker, max_dt)) {
    out.push_back({device[i].timestamp, {device[i].world_from_cam, marker[j].world_from_cam}});
  }
  return out;
}

void write_calibration(const std::filesystem::path& path, const CalibrationFile& calibration) {
  AtomicOutput out(path);
  out << std::setprecision(12);
  out << "# coloc handeye calibration: 4x4 row-major, metres (frames: see README, hand-eye)\n";
  auto matrix = [&](const char* key, const SE3& pose) {
    const Eigen::Matrix4d m = pose.matrix();
    out << key << ": [";
    for (int k = 0; k < 16; ++k)
      out << (k ? ", " : "") << m(k / 4, k % 4);
    out << "]\n";
  };
  matrix("device_from_marker", calibration.device_from_marker);
  matrix("vr_from_camera", calibration.vr_from_camera);
  out << "sigma: " << calibration.sigma << "\n";
  out.commit();
}

CalibrationFile read_calibration(const std::filesystem::path& path) {
  check_input_file(path, "calibration file");
  std::ifstream in(path);
  if (!in) throw Error("cannot open file", {.file = path.string()});
  Reader reader{path, 0};
  CalibrationFile out;
  bool seen_x = false, seen_y = false;
  std::string line;
  while (std::getline(in, line)) {
    ++reader.line;
    const std::size_t hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    const std::size_t colon = line.find(':');
    if (colon == std::string::npos) continue;
    const std::string key =
        split(line.substr(0, colon)).empty() ? "" : split(line.substr(0, colon))[0];
    std::string value = line.substr(colon + 1);
    std::replace(value.begin(), value.end(), '[', ' ');
    std::replace(value.begin(), value.end(), ']', ' ');
    const std::vector<std::string> fields = split(value);
    if (key == "sigma") {
      if (fields.size() != 1) reader.fail("expected one number", key);
      out.sigma = reader.number(fields[0], key);
      continue;
    }
    if (key != "device_from_marker" && key != "vr_from_camera") reader.fail("unknown key", key);
    if (fields.size() != 16) reader.fail("expected 16 numbers (4x4 row-major)", key);
    Eigen::Matrix4d m;
    for (int k = 0; k < 16; ++k)
      m(k / 4, k % 4) = reader.number(fields[k], key);
    (key == "device_from_marker" ? out.device_from_marker : out.vr_from_camera) =
        rigid_from_matrix(m, {.file = path.string(), .field = key, .line = reader.line});
    (key == "device_from_marker" ? seen_x : seen_y) = true;
  }
  if (!seen_x || !seen_y) {
    throw Error("missing key",
                {.file = path.string(), .field = seen_x ? "vr_from_camera" : "device_from_marker"});
  }
  return out;
}

}  // namespace coloc::registration::handeye
