#include "slam/settings/settings.hpp"

#include <spdlog/spdlog.h>

#include <Eigen/LU>
#include <cmath>
#include <fstream>
#include <opencv2/core.hpp>
#include <set>

#include "slam/core/error.hpp"
#include "slam/core/input_file.hpp"
#include "slam/core/rigid.hpp"
#include "slam/core/yaml_text.hpp"
#include "slam/settings/opencv_matrix.hpp"

namespace coloc::settings {
namespace {

constexpr int kMaxImageSide = 65535;
constexpr int kMaxFeatures = 100000;
constexpr std::size_t kMaxSettingsBytes = 1 << 20;

// Settings files go through the one YAML guard of slam/core (yaml_text.hpp): OpenCV 4.6's
// reader loops forever on some malformed input ("----x") and asserts on binary data.
std::string read_text(const std::filesystem::path& path) {
  return read_yaml_text(path, "settings file", {.max_bytes = kMaxSettingsBytes});
}

void check_text(const std::string& text, const std::filesystem::path& path) {
  check_yaml_text(text, path, "settings file");
}

// Typed access to the top-level keys of one file, remembering which keys were used so the
// rest can be reported.
class KeyReader {
 public:
  KeyReader(const std::string& text, const std::filesystem::path& path) : path_(path) {
    check_text(text, path);
    try {
      if (!storage_.open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY)) {
        throw Error("cannot open settings file", {.file = path.string()});
      }
      for (const auto& node : storage_.root())
        keys_.push_back(node.name());
    } catch (const cv::Exception& e) {
      throw Error("not a readable YAML settings file (" + std::string(e.err) + ")",
                  {.file = path.string()});
    }
  }

  bool has(const std::string& key) const { return !storage_[key].empty(); }

  std::optional<double> number(const std::string& key) {
    const cv::FileNode node = storage_[key];
    if (node.empty()) return std::nullopt;
    used_.insert(key);
    if (!node.isReal() && !node.isInt()) fail(key, "expected a number");
    const double value = node.real();
    // YAML's .nan / .inf parse as reals; no setting means either.
    if (!std::isfinite(value)) fail(key, "expected a finite number");
    return value;
  }

  double required_number(const std::string& key) {
    const auto v = number(key);
    if (!v) fail(key, "required key is missing");
    return *v;
  }

  std::optional<int> integer(const std::string& key) {
    const auto v = number(key);
    if (!v) return std::nullopt;
    if (std::floor(*v) != *v) fail(key, "expected an integer, got " + std::to_string(*v));
    if (std::abs(*v) > 1e9) fail(key, "integer " + std::to_string(*v) + " out of range");
    return static_cast<int>(*v);
  }

  std::optional<std::string> text(const std::string& key) {
    const cv::FileNode node = storage_[key];
    if (node.empty()) return std::nullopt;
    used_.insert(key);
    if (!node.isString()) fail(key, "expected a string");
    return static_cast<std::string>(node);
  }

  // A rigid transform as a 4x4 !!opencv-matrix (read_rigid_matrix: shape checked first, then
  // slam/core's rigid check).
  std::optional<SE3> transform(const std::string& key) {
    const cv::FileNode node = storage_[key];
    if (!node.empty()) used_.insert(key);
    return read_rigid_matrix(node, {.file = path_.string(), .field = key});
  }

  [[noreturn]] void fail(const std::string& key, const std::string& message) const {
    throw Error(message, {.file = path_.string(), .field = key});
  }

  const std::vector<std::string>& keys() const { return keys_; }
  bool used(const std::string& key) const { return used_.count(key) != 0; }

 private:
  std::filesystem::path path_;
  cv::FileStorage storage_;
  std::vector<std::string> keys_;
  std::set<std::string> used_;
};

bool starts_with(const std::string& s, const std::string& prefix) {
  return s.starts_with(prefix);
}

Camera read_camera(KeyReader& keys, int file_version) {
  // v1.0 names the first camera Camera1.*; older files use Camera.* for everything.
  const std::string p = file_version >= 1 ? "Camera1." : "Camera.";
  const std::string type = keys.text("Camera.type").value_or("PinHole");
  const int width = keys.integer("Camera.width").value_or(0);
  const int height = keys.integer("Camera.height").value_or(0);
  const double fx = keys.required_number(p + "fx");
  const double fy = keys.required_number(p + "fy");
  const double cx = keys.required_number(p + "cx");
  const double cy = keys.required_number(p + "cy");
  if (!(fx > 0.0)) keys.fail(p + "fx", "focal length must be positive (pixels)");
  if (!(fy > 0.0)) keys.fail(p + "fy", "focal length must be positive (pixels)");
  // 0 = not given; anything else is the image size, which a camera can actually have.
  if (width < 0 || width > kMaxImageSide) keys.fail("Camera.width", "must be in 1..65535 pixels");
  if (height < 0 || height > kMaxImageSide)
    keys.fail("Camera.height", "must be in 1..65535 pixels");
  auto coeff = [&](const std::string& k) { return keys.number(p + k).value_or(0.0); };
  if (type == "PinHole" || type == "Rectified") {
    return PinholeCamera{width,
                         height,
                         fx,
                         fy,
                         cx,
                         cy,
                         {coeff("k1"), coeff("k2"), coeff("p1"), coeff("p2"), coeff("k3")}};
  }
  if (type == "KannalaBrandt8") {
    return KannalaBrandtCamera{
        width, height, fx, fy, cx, cy, {coeff("k1"), coeff("k2"), coeff("k3"), coeff("k4")}};
  }
  keys.fail("Camera.type",
            "unknown camera model '" + type + "' (supported: PinHole, Rectified, KannalaBrandt8)");
}

std::optional<DepthSettings> read_depth(KeyReader& keys, int file_version, double fx) {
  DepthSettings d;
  std::optional<double> th;
  std::optional<double> factor;
  if (file_version >= 1) {
    const auto b = keys.number("Stereo.b");
    th = keys.number("Stereo.ThDepth");
    factor = keys.number("RGBD.DepthMapFactor");
    if (!b && !th && !factor) return std::nullopt;
    if (!b) keys.fail("Stereo.b", "required with Stereo.ThDepth / RGBD.DepthMapFactor");
    d.baseline = *b;
    d.bf = *b * fx;
  } else {
    const auto bf = keys.number("Camera.bf");
    th = keys.number("ThDepth");
    factor = keys.number("DepthMapFactor");
    if (!bf && !th && !factor) return std::nullopt;
    if (!bf) keys.fail("Camera.bf", "required with ThDepth / DepthMapFactor");
    d.bf = *bf;
    d.baseline = *bf / fx;
  }
  if (!(d.baseline > 0.0)) keys.fail(file_version >= 1 ? "Stereo.b" : "Camera.bf", "must be > 0");
  d.th_depth = th.value_or(40.0);
  d.close_depth = d.baseline * d.th_depth;
  if (!(d.th_depth >= 0.0))
    keys.fail(file_version >= 1 ? "Stereo.ThDepth" : "ThDepth", "must not be negative");
  d.depth_map_factor = factor.value_or(1.0);
  // ORB-SLAM silently reads 0 as "depth already in metres"; a zero scale is more often a typo,
  // and every depth would become 0 or infinite, so the unit is asked for explicitly.
  if (!(d.depth_map_factor > 0.0)) {
    keys.fail(file_version >= 1 ? "RGBD.DepthMapFactor" : "DepthMapFactor",
              "must be positive (raw depth units per metre: 5000 TUM, 1000 millimetres, 1 metres)");
  }
  return d;
}

OrbSettings read_orb(KeyReader& keys) {
  OrbSettings o;
  o.n_features = keys.integer("ORBextractor.nFeatures").value_or(o.n_features);
  o.scale_factor = keys.number("ORBextractor.scaleFactor").value_or(o.scale_factor);
  o.n_levels = keys.integer("ORBextractor.nLevels").value_or(o.n_levels);
  o.ini_th_fast = keys.integer("ORBextractor.iniThFAST").value_or(o.ini_th_fast);
  o.min_th_fast = keys.integer("ORBextractor.minThFAST").value_or(o.min_th_fast);
  // Upper bounds: far beyond any useful value, low enough that the extractor's buffers (sized
  // by them) cannot exhaust memory.
  if (o.n_features <= 0 || o.n_features > kMaxFeatures)
    keys.fail("ORBextractor.nFeatures", "must be in 1..100000");
  if (!(o.scale_factor > 1.0 && o.scale_factor <= 4.0))
    keys.fail("ORBextractor.scaleFactor", "must be in (1, 4]");
  if (o.n_levels <= 0 || o.n_levels > 32) keys.fail("ORBextractor.nLevels", "must be in 1..32");
  if (o.ini_th_fast < 1 || o.ini_th_fast > 254)
    keys.fail("ORBextractor.iniThFAST", "must be in 1..254 (grey levels)");
  if (o.min_th_fast < 1 || o.min_th_fast > 254)
    keys.fail("ORBextractor.minThFAST", "must be in 1..254 (grey levels)");
  return o;
}

// ORB-SLAM3 v1.0's atlas file keys name our map database: a name without an extension gets
// ".db" (ORB-SLAM3 appends ".osa"); relative paths stay relative to the working directory, as
// there.
std::filesystem::path map_file(KeyReader& keys, const std::string& key) {
  const auto name = keys.text(key);
  if (!name) return {};
  if (name->empty()) keys.fail(key, "empty file name");
  std::filesystem::path p(*name);
  if (!p.has_extension()) p += ".db";
  return p;
}

Settings read_settings(const std::string& text, const std::filesystem::path& path) {
  KeyReader keys(text, path);
  Settings s;
  s.source = path;
  if (const auto version = keys.text("File.version")) {
    if (*version != "1.0") keys.fail("File.version", "unsupported version '" + *version + "'");
    s.file_version = 1;
  }
  s.camera = read_camera(keys, s.file_version);
  s.fps = keys.number("Camera.fps").value_or(s.fps);
  if (!(s.fps > 0.0 && s.fps <= 10000.0)) keys.fail("Camera.fps", "must be in (0, 10000] Hz");
  s.rgb_order = keys.integer("Camera.RGB").value_or(0) != 0;  // ORB-SLAM: absent = BGR
  s.readout_time = keys.number("Camera.readoutTime");
  if (s.readout_time && !(*s.readout_time >= 0.0 && *s.readout_time < 1.0))
    keys.fail("Camera.readoutTime", "must be in [0, 1) seconds");
  if (const auto t = keys.transform("IMU.T_b_c1")) s.imu_from_cam = *t;
  s.gyro_noise_density = keys.number("IMU.NoiseGyro");
  if (s.gyro_noise_density && !(*s.gyro_noise_density > 0.0 && *s.gyro_noise_density < 1.0))
    keys.fail("IMU.NoiseGyro", "must be in (0, 1) rad/s/sqrt(Hz)");
  s.gyro_random_walk = keys.number("IMU.GyroWalk");
  if (s.gyro_random_walk && !(*s.gyro_random_walk > 0.0 && *s.gyro_random_walk < 1.0))
    keys.fail("IMU.GyroWalk", "must be in (0, 1) rad/s^2/sqrt(Hz)");
  // ORB-SLAM3's other IMU keys (its IMU-RGBD files, and the twin's camera.yaml, which ORB-SLAM3
  // must also run with): checked, and known, but not used. coloc's gravity term is limited by
  // the walk's own accelerations, far above the accelerometer's noise, and tracking makes no
  // keyframe while lost.
  for (const char* key : {"IMU.NoiseAcc", "IMU.AccWalk", "IMU.Frequency"}) {
    if (const auto v = keys.number(key); v && !(std::isfinite(*v) && *v > 0.0))
      keys.fail(key, "must be a positive number");
  }
  if (const auto v = keys.number("IMU.InsertKFsWhenLost"); v && *v != 0.0 && *v != 1.0)
    keys.fail("IMU.InsertKFsWhenLost", "must be 0 or 1");
  s.depth = read_depth(keys, s.file_version, intrinsic_matrix(s.camera)(0, 0));
  s.orb = read_orb(keys);
  s.markers.dictionary = keys.text("Markers.dictionary").value_or(s.markers.dictionary);
  s.markers.size = keys.number("Markers.size").value_or(s.markers.size);
  if (!(s.markers.size > 0.0)) keys.fail("Markers.size", "must be positive (metres)");

  s.load_map = map_file(keys, "System.LoadAtlasFromFile");
  s.save_map = map_file(keys, "System.SaveAtlasToFile");

  for (const auto& key : keys.keys()) {
    if (keys.used(key) || starts_with(key, "Viewer.")) continue;
    if (starts_with(key, "Coloc.")) {
      s.coloc_options[key.substr(6)] = keys.required_number(key);
      continue;
    }
    s.warnings.push_back(key);
    spdlog::warn("{}: unknown key '{}' ignored", path.string(), key);
  }
  return s;
}

}  // namespace

Settings load_settings(const std::filesystem::path& path) {
  check_input_file(path, "settings file");
  return parse_settings(read_text(path), path.string());
}

Settings parse_settings(const std::string& text, const std::string& source) {
  try {
    return read_settings(text, source);
  } catch (const cv::Exception& e) {
    // OpenCV asserts on some malformed nodes only when they are read.
    throw Error("not a readable YAML settings file (" + std::string(e.err) + ")", {.file = source});
  }
}

}  // namespace coloc::settings
