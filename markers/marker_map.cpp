#include "markers/marker_map.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <opencv2/core.hpp>
#include <string_view>

#include "slam/core/atomic_file.hpp"
#include "slam/core/error.hpp"
#include "slam/core/input_file.hpp"
#include "slam/core/yaml_text.hpp"

namespace coloc::markers {
namespace {

constexpr std::string_view kFormatName = "coloc-marker-map";
constexpr int kFormatVersion = 1;

class Reader {
 public:
  explicit Reader(std::filesystem::path path) : path_(std::move(path)) {}

  [[noreturn]] void fail(const std::string& message, const std::string& field) const {
    throw Error(message, {.file = path_.string(), .field = field});
  }

  void only_keys(const cv::FileNode& node, const std::string& where,
                 std::initializer_list<const char*> allowed) const {
    for (const std::string& key : node.keys()) {
      if (std::none_of(allowed.begin(), allowed.end(), [&](const char* a) { return key == a; })) {
        std::string field = where;
        if (!field.empty()) field += '.';
        fail("unknown key", field + key);
      }
    }
  }

  std::string string(const cv::FileNode& node, const std::string& field, bool required) const {
    if (node.empty()) {
      if (required) fail("missing key", field);
      return {};
    }
    if (!node.isString()) fail("must be a string", field);
    return static_cast<std::string>(node);
  }

  double number(const cv::FileNode& node, const std::string& field, bool required) const {
    if (node.empty()) {
      if (required) fail("missing key", field);
      return 0.0;
    }
    if (!node.isInt() && !node.isReal()) fail("must be a number", field);
    return static_cast<double>(node);
  }

  int integer(const cv::FileNode& node, const std::string& field, bool required) const {
    if (node.empty()) {
      if (required) fail("missing key", field);
      return 0;
    }
    if (!node.isInt()) fail("must be an integer", field);
    return static_cast<int>(node);
  }

  std::vector<std::string> strings(const cv::FileNode& node, const std::string& field) const {
    std::vector<std::string> out;
    if (node.empty()) return out;
    if (!node.isSeq()) fail("must be a list of strings", field);
    for (int i = 0; i < static_cast<int>(node.size()); ++i) {
      out.push_back(string(node[i], field + "[" + std::to_string(i) + "]", true));
    }
    return out;
  }

  MapMarker marker(const cv::FileNode& node, const std::string& where) const {
    if (!node.isMap()) fail("must be a mapping", where);
    only_keys(node, where,
              {"id", "edge_length", "corners", "sightings", "rejected_sightings",
               "ambiguous_sightings", "residual", "images"});
    MapMarker m;
    m.id = integer(node["id"], where + ".id", true);
    if (m.id < 0) fail("must be non-negative", where + ".id");
    m.edge_length = number(node["edge_length"], where + ".edge_length", true);
    if (!(m.edge_length > 0.0)) fail("must be positive (metres)", where + ".edge_length");
    const cv::FileNode corners = node["corners"];
    const std::string cf = where + ".corners";
    if (corners.empty()) fail("missing key", cf);
    if (!corners.isSeq() || corners.size() != 12) {
      fail("must be a list of 12 numbers (4 corners x y z)", cf);
    }
    for (int i = 0; i < 12; ++i) {
      const std::string field = cf + "[" + std::to_string(i) + "]";
      m.corners[i / 3][i % 3] = number(corners[i], field, true);
      // A NaN or infinite corner is a broken file, not an outlier for registration to drop.
      if (!std::isfinite(m.corners[i / 3][i % 3]))
        fail("marker " + std::to_string(m.id) + ": corner " + std::to_string(i / 3) +
                 " has a non-finite coordinate",
             field);
    }
    m.sightings = integer(node["sightings"], where + ".sightings", false);
    m.rejected_sightings =
        integer(node["rejected_sightings"], where + ".rejected_sightings", false);
    m.ambiguous_sightings =
        integer(node["ambiguous_sightings"], where + ".ambiguous_sightings", false);
    m.residual = number(node["residual"], where + ".residual", false);
    if (!std::isfinite(m.residual))
      fail("marker " + std::to_string(m.id) + ": non-finite residual", where + ".residual");
    m.images = strings(node["images"], where + ".images");
    return m;
  }

 private:
  std::filesystem::path path_;
};

}  // namespace

Eigen::Vector3d MapMarker::centre() const {
  return 0.25 * (corners[0] + corners[1] + corners[2] + corners[3]);
}

Eigen::Vector3d MapMarker::normal() const {
  // x runs 0 -> 1 (and 3 -> 2), y runs 3 -> 0 (and 2 -> 1); z = x cross y points out of the face.
  const Eigen::Vector3d x = (corners[1] - corners[0]) + (corners[2] - corners[3]);
  const Eigen::Vector3d y = (corners[0] - corners[3]) + (corners[1] - corners[2]);
  return x.cross(y).normalized();
}

void write_marker_map(const std::filesystem::path& path, const MarkerMap& map) {
  // Composed in memory (OpenCV picks YAML or JSON from the name's extension) and written
  // atomically; the output folder is checked before.
  AtomicFile output(path);
  cv::FileStorage fs;
  try {
    fs.open(path.filename().string(), cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  } catch (const cv::Exception& e) {
    throw Error(std::string("cannot write marker map: ") + e.what(), {.file = path.string()});
  }
  if (!fs.isOpened()) throw Error("cannot write marker map", {.file = path.string()});
  fs << "format" << std::string(kFormatName) << "version" << kFormatVersion;
  fs << "dictionary" << map.dictionary << "frame" << map.frame << "source" << map.source;
  fs << "images"
     << "[";
  for (const std::string& image : map.images)
    fs << image;
  fs << "]";
  fs << "markers"
     << "[";
  for (const auto& [id, m] : map.markers) {
    fs << "{"
       << "id" << id << "edge_length" << m.edge_length;
    fs << "corners"
       << "[:";
    for (const Eigen::Vector3d& c : m.corners)
      fs << c.x() << c.y() << c.z();
    fs << "]";
    fs << "sightings" << m.sightings << "rejected_sightings" << m.rejected_sightings
       << "ambiguous_sightings" << m.ambiguous_sightings << "residual" << m.residual;
    fs << "images"
       << "[";
    for (const std::string& image : m.images)
      fs << image;
    fs << "]"
       << "}";
  }
  fs << "]";
  write_file_atomically(output.target(), fs.releaseAndGetString());
}

namespace {

MarkerMap read_marker_map_text(const std::filesystem::path& path) {
  // Through the YAML guard (OpenCV's reader can loop forever on some malformed input).
  const std::string text = read_yaml_text(path, "marker map");
  cv::FileStorage fs;
  try {
    fs.open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY);
  } catch (const cv::Exception& e) {
    throw Error(std::string("cannot parse marker map: ") + e.what(), {.file = path.string()});
  }
  if (!fs.isOpened()) throw Error("cannot open marker map", {.file = path.string()});
  const Reader r(path);
  const cv::FileNode root = fs.root();
  if (!root.isMap()) r.fail("top level must be a mapping", "");
  r.only_keys(root, "",
              {"format", "version", "dictionary", "frame", "source", "images", "markers"});
  if (r.string(root["format"], "format", true) != kFormatName) {
    r.fail("not a coloc marker map (want format: " + std::string(kFormatName) + ")", "format");
  }
  const int version = r.integer(root["version"], "version", true);
  if (version != kFormatVersion)
    r.fail("unsupported version " + std::to_string(version), "version");
  MarkerMap map;
  map.dictionary = r.string(root["dictionary"], "dictionary", true);
  map.frame = r.string(root["frame"], "frame", false);
  map.source = r.string(root["source"], "source", false);
  map.images = r.strings(root["images"], "images");
  const cv::FileNode markers = root["markers"];
  if (markers.empty()) r.fail("missing key", "markers");
  if (!markers.isSeq()) r.fail("must be a list", "markers");
  for (int i = 0; i < static_cast<int>(markers.size()); ++i) {
    const std::string where = "markers[" + std::to_string(i) + "]";
    MapMarker m = r.marker(markers[i], where);
    if (map.markers.count(m.id) != 0) r.fail("duplicate marker id " + std::to_string(m.id), where);
    map.markers.emplace(m.id, std::move(m));
  }
  return map;
}

}  // namespace

MarkerMap read_marker_map(const std::filesystem::path& path) {
  return read_naming_file(path, "marker map", [&] { return read_marker_map_text(path); });
}

}  // namespace coloc::markers
