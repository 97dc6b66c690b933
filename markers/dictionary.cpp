#include "markers/dictionary.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <filesystem>
#include <opencv2/core.hpp>
#include <utility>

#include "slam/core/error.hpp"
#include "slam/core/input_file.hpp"
#include "slam/core/yaml_text.hpp"

namespace coloc::markers {
namespace {

using cv::aruco::PREDEFINED_DICTIONARY_NAME;

const std::array<std::pair<const char*, PREDEFINED_DICTIONARY_NAME>, 21> kDictionaries{{
    {"DICT_4X4_50", cv::aruco::DICT_4X4_50},
    {"DICT_4X4_100", cv::aruco::DICT_4X4_100},
    {"DICT_4X4_250", cv::aruco::DICT_4X4_250},
    {"DICT_4X4_1000", cv::aruco::DICT_4X4_1000},
    {"DICT_5X5_50", cv::aruco::DICT_5X5_50},
    {"DICT_5X5_100", cv::aruco::DICT_5X5_100},
    {"DICT_5X5_250", cv::aruco::DICT_5X5_250},
    {"DICT_5X5_1000", cv::aruco::DICT_5X5_1000},
    {"DICT_6X6_50", cv::aruco::DICT_6X6_50},
    {"DICT_6X6_100", cv::aruco::DICT_6X6_100},
    {"DICT_6X6_250", cv::aruco::DICT_6X6_250},
    {"DICT_6X6_1000", cv::aruco::DICT_6X6_1000},
    {"DICT_7X7_50", cv::aruco::DICT_7X7_50},
    {"DICT_7X7_100", cv::aruco::DICT_7X7_100},
    {"DICT_7X7_250", cv::aruco::DICT_7X7_250},
    {"DICT_7X7_1000", cv::aruco::DICT_7X7_1000},
    {"DICT_ARUCO_ORIGINAL", cv::aruco::DICT_ARUCO_ORIGINAL},
    {"DICT_APRILTAG_16h5", cv::aruco::DICT_APRILTAG_16h5},
    {"DICT_APRILTAG_25h9", cv::aruco::DICT_APRILTAG_25h9},
    {"DICT_APRILTAG_36h10", cv::aruco::DICT_APRILTAG_36h10},
    {"DICT_APRILTAG_36h11", cv::aruco::DICT_APRILTAG_36h11},
}};

std::string upper(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
  return s;
}

bool looks_like_file(const std::string& s) {
  const std::string ext = std::filesystem::path(s).extension().string();
  return ext == ".yml" || ext == ".yaml" || ext == ".json" || ext == ".xml";
}

namespace {

cv::Ptr<cv::aruco::Dictionary> read_dictionary_text(const std::string& path) {
  ErrorContext ctx{.file = path};
  // Through the YAML guard (OpenCV's reader can loop forever on some malformed input).
  const std::string text = read_yaml_text(path, "dictionary file");
  cv::FileStorage fs;
  try {
    fs.open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY);
  } catch (const cv::Exception& e) {
    throw Error(std::string("cannot parse dictionary file: ") + e.what(), ctx);
  }
  if (!fs.isOpened()) throw Error("cannot open dictionary file", ctx);
  const cv::FileNode root = fs.root();
  for (const char* key : {"nmarkers", "markersize"}) {
    if (root[key].empty() || !root[key].isInt()) {
      throw Error("missing or non-integer key", {.file = path, .field = key});
    }
  }
  const int n = static_cast<int>(root["nmarkers"]);
  const int bits = static_cast<int>(root["markersize"]);
  if (n <= 0 || bits <= 0 || bits > 16) {
    throw Error("nmarkers and markersize must be positive (markersize <= 16)",
                {.file = path, .field = "markersize"});
  }
  for (int i = 0; i < n; ++i) {
    const std::string key = "marker_" + std::to_string(i);
    const cv::FileNode node = root[key];
    if (node.empty() || !node.isString() ||
        static_cast<int>(static_cast<std::string>(node).size()) != bits * bits) {
      throw Error("missing marker or wrong bit count (want markersize^2 characters of 0/1)",
                  {.file = path, .field = key});
    }
  }
  auto dictionary = cv::makePtr<cv::aruco::Dictionary>();
  if (!dictionary->readDictionary(root)) throw Error("cannot read the dictionary", ctx);
  return dictionary;
}

}  // namespace

cv::Ptr<cv::aruco::Dictionary> read_custom_dictionary(const std::string& path) {
  return read_naming_file(path, "dictionary file", [&] { return read_dictionary_text(path); });
}

}  // namespace

std::vector<std::string> dictionary_names() {
  std::vector<std::string> names;
  for (const auto& [name, id] : kDictionaries)
    names.emplace_back(name);
  return names;
}

cv::Ptr<cv::aruco::Dictionary> make_dictionary(const std::string& name_or_path) {
  if (looks_like_file(name_or_path)) return read_custom_dictionary(name_or_path);
  // OpenCV's numeric ids (cv::aruco::PREDEFINED_DICTIONARY_NAME), as the twin's files write them.
  if (!name_or_path.empty() && name_or_path.size() <= 2 &&
      std::all_of(name_or_path.begin(), name_or_path.end(),
                  [](unsigned char c) { return std::isdigit(c) != 0; })) {
    const std::size_t index = std::stoul(name_or_path);
    if (index < kDictionaries.size()) {
      return cv::aruco::getPredefinedDictionary(kDictionaries[index].second);
    }
  }
  std::string wanted = upper(name_or_path);
  if (wanted.rfind("DICT_", 0) != 0) wanted = "DICT_" + wanted;
  for (const auto& [name, id] : kDictionaries) {
    if (upper(name) == wanted) return cv::aruco::getPredefinedDictionary(id);
  }
  std::string known;
  for (const auto& [name, id] : kDictionaries)
    known += std::string(known.empty() ? "" : ", ") + name;
  throw Error("unknown marker dictionary '" + name_or_path + "' (known: " + known +
                  ", or a dictionary .yml file)",
              {.field = "dictionary"});
}

}  // namespace coloc::markers
