#include "fusion/session/config.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "slam/core/error.hpp"
#include "slam/core/rigid.hpp"
#include "slam/core/yaml_text.hpp"

namespace coloc::fusion::session {
namespace {

// Where a value sits: the file, its 1-based line and the field path, for every error.
struct Where {
  const std::filesystem::path& origin;
  std::string field;

  [[noreturn]] void fail(const std::string& message, const YAML::Node& node) const {
    ErrorContext context{.file = origin.string(), .field = field};
    if (node.IsDefined() && node.Mark().line >= 0) context.line = node.Mark().line + 1;
    throw Error(message, context);
  }
  Where child(const std::string& key) const {
    return {origin, field.empty() ? key : field + "." + key};
  }
  Where item(std::size_t i) const { return {origin, field + "[" + std::to_string(i) + "]"}; }
};

// Every key of `node` must be in `allowed` (a misspelt key is an error, DESIGN.md section 3).
void check_keys(const YAML::Node& node, const Where& where,
                std::initializer_list<std::string_view> allowed) {
  if (!node.IsMap()) where.fail("expected a mapping", node);
  for (const auto& entry : node) {
    const auto key = entry.first.as<std::string>();
    if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
      where.child(key).fail("unknown key", entry.first);
    }
  }
}

template <typename T>
T scalar(const YAML::Node& node, const Where& where, const char* what) {
  if (!node.IsScalar()) where.fail(std::string("expected ") + what, node);
  try {
    return node.as<T>();
  } catch (const YAML::Exception&) {
    where.fail(std::string("expected ") + what + ", got '" + node.Scalar() + "'", node);
  }
}

// A pose: 16 numbers (4x4 row-major, as `coloc handeye solve --output` writes) or 7 numbers
// (tx ty tz qx qy qz qw).
SE3 pose(const YAML::Node& node, const Where& where) {
  if (!node.IsSequence() || (node.size() != 16 && node.size() != 7)) {
    where.fail("expected 16 numbers (4x4 row-major) or 7 (tx ty tz qx qy qz qw)", node);
  }
  std::vector<double> v;
  for (std::size_t i = 0; i < node.size(); ++i)
    v.push_back(scalar<double>(node[i], where.item(i), "a number"));
  if (!std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); })) {
    where.fail("non-finite number", node);
  }
  // The one rigid check of slam/core; its message, with this key's place in the file.
  try {
    if (v.size() == 7)
      return rigid_from_quaternion({v[0], v[1], v[2]}, {v[3], v[4], v[5], v[6]}, {});
    Eigen::Matrix4d m;
    for (int k = 0; k < 16; ++k)
      m(k / 4, k % 4) = v[k];
    return rigid_from_matrix(m, {});
  } catch (const Error& e) {
    where.fail(e.message(), node);
  }
}

AnchorConfig parse_anchor(const YAML::Node& node, const Where& where) {
  check_keys(
      node, where,
      {"camera", "world_from_camera", "world_from_marker", "camera_from_marker", "localize"});
  AnchorConfig a;
  if (node["camera"]) a.camera = scalar<std::string>(node["camera"], where.child("camera"), "text");
  const bool fixed = static_cast<bool>(node["world_from_camera"]);
  const bool marker = node["world_from_marker"] || node["camera_from_marker"];
  const bool localize = static_cast<bool>(node["localize"]);
  if (int(fixed) + int(marker) + int(localize) != 1) {
    where.fail(
        "give exactly one of world_from_camera, world_from_marker + camera_from_marker, "
        "localize",
        node);
  }
  if (fixed)
    a.world_from_camera = pose(node["world_from_camera"], where.child("world_from_camera"));
  if (marker) {
    for (const char* key : {"world_from_marker", "camera_from_marker"}) {
      if (!node[key]) where.child(key).fail("missing (the marker needs both poses)", node);
    }
    // The floor marker's pose in the scan and the camera's PnP of it.
    a.world_from_camera =
        pose(node["world_from_marker"], where.child("world_from_marker")) *
        pose(node["camera_from_marker"], where.child("camera_from_marker")).inverse();
  }
  if (localize) {
    const YAML::Node l = node["localize"];
    const Where w = where.child("localize");
    check_keys(l, w, {"port", "poses"});
    a.mode = AnchorMode::kLocalize;
    if (!l["port"]) w.child("port").fail("missing", l);
    a.localize_port = scalar<int>(l["port"], w.child("port"), "an integer");
    if (l["poses"]) a.localize_poses = scalar<int>(l["poses"], w.child("poses"), "an integer");
    if (a.localize_port <= 0 || a.localize_port > 65535) w.child("port").fail("out of range", l);
    if (a.localize_poses < 1) w.child("poses").fail("must be >= 1", l);
  }
  return a;
}

ParticipantKind parse_kind(const YAML::Node& node, const Where& where) {
  const auto text = scalar<std::string>(node, where, "vr, ar or mr");
  if (text == "vr") return ParticipantKind::kVr;
  if (text == "ar") return ParticipantKind::kAr;
  if (text == "mr") return ParticipantKind::kMr;
  where.fail("expected vr, ar or mr, got '" + text + "'", node);
}

ParticipantConfig parse_participant(const YAML::Node& node, const Where& where,
                                    const std::filesystem::path& base, bool drift_default) {
  check_keys(node, where,
             {"id", "kind", "system", "calibration", "port", "controllers", "drift_correction"});
  ParticipantConfig p;
  for (const char* key : {"id", "kind", "calibration"}) {
    if (!node[key]) where.child(key).fail("missing", node);
  }
  p.id = scalar<std::string>(node["id"], where.child("id"), "text");
  p.kind = parse_kind(node["kind"], where.child("kind"));
  if (node["system"]) p.system = scalar<std::string>(node["system"], where.child("system"), "text");
  const std::filesystem::path calibration =
      scalar<std::string>(node["calibration"], where.child("calibration"), "a file name");
  p.calibration = calibration.is_absolute() ? calibration : base / calibration;
  if (node["port"]) p.port = scalar<int>(node["port"], where.child("port"), "an integer");
  if (node["controllers"]) {
    p.controllers = scalar<int>(node["controllers"], where.child("controllers"), "an integer");
  }
  p.drift_correction = drift_default;
  if (node["drift_correction"]) {
    p.drift_correction =
        scalar<bool>(node["drift_correction"], where.child("drift_correction"), "true or false");
  }
  return p;
}

bool valid_id(const std::string& id) {
  return !id.empty() && id.size() <= 64 && std::all_of(id.begin(), id.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_' || c == '-';
  });
}

}  // namespace

const char* to_string(ParticipantKind kind) {
  switch (kind) {
    case ParticipantKind::kVr:
      return "vr";
    case ParticipantKind::kAr:
      return "ar";
    case ParticipantKind::kMr:
      return "mr";
  }
  return "?";
}

void SessionConfig::check() const {
  const auto fail = [&](const std::string& field, const std::string& message) {
    throw Error(message, ErrorContext{.file = file.string(), .field = field});
  };
  if (!(stale_after > 0.0)) fail("stale_after", "must be > 0 s");
  if (participants.empty()) fail("participants", "at least one participant is needed");
  std::set<std::string> ids;
  std::set<int> ports;
  if (anchor.mode == AnchorMode::kLocalize) ports.insert(anchor.localize_port);
  for (std::size_t i = 0; i < participants.size(); ++i) {
    const ParticipantConfig& p = participants[i];
    const std::string at = "participants[" + std::to_string(i) + "].";
    if (!valid_id(p.id)) fail(at + "id", "'" + p.id + "': use 1-64 of A-Z a-z 0-9 _ -");
    if (!ids.insert(p.id).second) fail(at + "id", "'" + p.id + "' is used twice");
    if (p.port < 0 || p.port > 65535) fail(at + "port", "must be in 0..65535");
    if (p.port > 0 && !ports.insert(p.port).second) {
      fail(at + "port", std::to_string(p.port) + " is used twice");
    }
    if (p.controllers < 0 || p.controllers > kMaxControllers) {
      fail(at + "controllers", "must be in 0.." + std::to_string(kMaxControllers));
    }
    if (p.calibration.empty()) fail(at + "calibration", "missing");
  }
}

const ParticipantConfig* SessionConfig::find(std::string_view id) const {
  for (const ParticipantConfig& p : participants) {
    if (p.id == id) return &p;
  }
  return nullptr;
}

namespace {

SessionConfig parse_session_text(const std::string& text, const std::filesystem::path& origin) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw Error("not YAML: " + e.msg,
                ErrorContext{.file = origin.string(),
                             .line = e.mark.line >= 0 ? std::optional<std::int64_t>(e.mark.line + 1)
                                                      : std::nullopt});
  }
  const Where where{origin, ""};
  check_keys(root, where, {"anchor", "participants", "stale_after", "drift_correction"});
  SessionConfig c;
  c.file = origin;
  if (!root["anchor"]) where.child("anchor").fail("missing", root);
  c.anchor = parse_anchor(root["anchor"], where.child("anchor"));
  if (root["stale_after"]) {
    c.stale_after = scalar<double>(root["stale_after"], where.child("stale_after"), "seconds");
  }
  bool drift_default = true;
  if (root["drift_correction"]) {
    drift_default =
        scalar<bool>(root["drift_correction"], where.child("drift_correction"), "true or false");
  }
  const YAML::Node list = root["participants"];
  if (!list || !list.IsSequence()) where.child("participants").fail("expected a list", root);
  const std::filesystem::path base = origin.has_parent_path() ? origin.parent_path() : ".";
  for (std::size_t i = 0; i < list.size(); ++i) {
    c.participants.push_back(
        parse_participant(list[i], where.child("participants").item(i), base, drift_default));
  }
  c.check();
  return c;
}

}  // namespace

SessionConfig parse_session_config(const std::string& text, const std::filesystem::path& origin) {
  return read_naming_file(origin, "session file", [&] { return parse_session_text(text, origin); });
}

SessionConfig read_session_config(const std::filesystem::path& path) {
  // The one YAML loader: a FIFO (which hung `session check`), a directory or a huge file is an
  // error saying what the path is.
  return parse_session_config(read_yaml_text(path, "session file"), path);
}

}  // namespace coloc::fusion::session
