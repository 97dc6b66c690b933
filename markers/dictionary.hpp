#pragma once
// ArUco / AprilTag dictionaries by name. The names are OpenCV's (`DICT_6X6_250`,
// `DICT_APRILTAG_36h11`, ...), matched case-insensitively and with or without the `DICT_` prefix;
// OpenCV's numeric id ("0" = DICT_4X4_50 ... "20" = DICT_APRILTAG_36h11) is accepted too; a path
// to a YAML file in OpenCV's dictionary format (`nmarkers`, `markersize`, `marker_N`: bit
// strings, as aruco's tutorial_dict.yml) loads a custom dictionary.

#include <opencv2/aruco/dictionary.hpp>
#include <string>
#include <vector>

namespace coloc::markers {

// Throws coloc::Error naming the dictionary (and the file and key, for custom files) when the
// name is unknown or the file is malformed.
cv::Ptr<cv::aruco::Dictionary> make_dictionary(const std::string& name_or_path);

// The predefined names, for --help texts and error messages.
std::vector<std::string> dictionary_names();

}  // namespace coloc::markers
