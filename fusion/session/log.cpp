#include "fusion/session/log.hpp"

#include <charconv>
#include <fstream>
#include <sstream>

#include "registration/handeye/compose.hpp"
#include "registration/handeye/io.hpp"
#include "slam/core/error.hpp"
#include "slam/core/input_file.hpp"

namespace coloc::fusion::session {
namespace {

namespace he = registration::handeye;

constexpr const char* kHeader =
    "receive_time,participant,device,time,sequence,state,tx,ty,tz,qx,qy,qz,qw";

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> fields;
  std::string field;
  std::istringstream in(line);
  while (std::getline(in, field, ','))
    fields.push_back(field);
  if (!line.empty() && line.back() == ',') fields.emplace_back();
  return fields;
}

double number(const std::string& text, const std::filesystem::path& path, std::int64_t line,
              const char* field) {
  double v = 0.0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size()) {
    throw Error("not a number: '" + text + "'",
                ErrorContext{.file = path.string(), .field = field, .line = line});
  }
  return v;
}

std::vector<he::TimedPose> controller_poses(const std::vector<LogRecord>& log,
                                            const std::string& id, int n) {
  const std::string device = "controller/" + std::to_string(n);
  std::vector<he::TimedPose> poses;
  for (const LogRecord& r : log) {
    if (r.participant == id && r.device == device) poses.push_back({r.receive_time, r.pose.pose()});
  }
  return poses;
}

}  // namespace

void write_log_header(std::ostream& out) {
  out << kHeader << '\n';
}

void write_log_record(std::ostream& out, const LogRecord& r) {
  const PoseMessage& p = r.pose;
  char line[320];
  std::snprintf(line, sizeof(line), "%.6f,%s,%s,%.6f,%d,%d,%.6f,%.6f,%.6f,%.7f,%.7f,%.7f,%.7f\n",
                r.receive_time, r.participant.c_str(), r.device.c_str(), p.time, p.sequence,
                p.state, p.position.x(), p.position.y(), p.position.z(), p.orientation.x(),
                p.orientation.y(), p.orientation.z(), p.orientation.w());
  out << line;
}

std::vector<LogRecord> read_session_log(const std::filesystem::path& path) {
  check_input_file(path, "session log");  // a FIFO would block, a directory reads as empty
  std::ifstream in(path);
  if (!in) throw Error("cannot open the session log", ErrorContext{.file = path.string()});
  std::vector<LogRecord> records;
  std::string text;
  std::int64_t line = 0;
  static const char* names[] = {"receive_time", "participant", "device", "time", "sequence",
                                "state",        "tx",          "ty",     "tz",   "qx",
                                "qy",           "qz",          "qw"};
  while (std::getline(in, text)) {
    ++line;
    if (text.empty() || text == kHeader || text[0] == '#') continue;
    const std::vector<std::string> f = split(text);
    if (f.size() != 13) {
      throw Error("expected 13 fields, got " + std::to_string(f.size()),
                  ErrorContext{.file = path.string(), .line = line});
    }
    double v[13] = {};
    for (const int i : {0, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12})
      v[i] = number(f[i], path, line, names[i]);
    LogRecord r{v[0], f[1], f[2], {}};
    r.pose.time = v[3];
    r.pose.sequence = static_cast<std::int32_t>(v[4]);
    r.pose.state = static_cast<std::int32_t>(v[5]);
    r.pose.position = {v[6], v[7], v[8]};
    r.pose.orientation = Eigen::Quaterniond(v[12], v[9], v[10], v[11]).normalized();
    records.push_back(std::move(r));
  }
  return records;
}

StabilityRow locked_stability(const std::vector<LogRecord>& log, const SessionConfig& config,
                              const std::string& a, int na, const std::string& b, int nb,
                              double max_dt) {
  const ParticipantConfig* pa = config.find(a);
  const ParticipantConfig* pb = config.find(b);
  if (pa == nullptr || pb == nullptr) {
    throw Error("unknown participant '" + (pa == nullptr ? a : b) + "'",
                ErrorContext{.file = config.file.string(), .field = "participants"});
  }
  const auto matched =
      he::match_by_time(controller_poses(log, a, na), controller_poses(log, b, nb), max_dt);
  if (matched.empty()) {
    throw Error("no poses of " + a + " controller " + std::to_string(na) + " and " + b +
                " controller " + std::to_string(nb) + " within " + std::to_string(max_dt) +
                " s of each other in the log");
  }
  std::vector<SE3> va, vb;
  for (const auto& m : matched) {
    va.push_back(m.registration.vr_from_device);
    vb.push_back(m.registration.camera_from_marker);  // here: vr_b_from_device_b
  }
  return stability_row(va, vb, he::read_calibration(pa->calibration).vr_from_camera,
                       he::read_calibration(pb->calibration).vr_from_camera);
}

}  // namespace coloc::fusion::session
