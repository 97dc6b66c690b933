#pragma once
// The one way a YAML file is read before it is parsed (by OpenCV's FileStorage from memory, or
// by yaml-cpp). OpenCV 4.6's YAML reader loops forever on a line of four or more dashes
// followed by more text ("----x", found by scripts/fuzz_settings) and asserts on some binary
// input; a FIFO or a device never ends. So every YAML reader takes its text from here: the
// path checked (check_input_file), the size bounded, a NUL byte and a line starting with "---"
// other than the document marker refused, each as a coloc::Error naming the file (and line).
// Dashes at the start of a line have one use in the YAML we read: the marker "---".
#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>

namespace coloc {

struct YamlTextOptions {
  std::size_t max_bytes = std::size_t{16} << 20;  // larger is refused: not a file of ours
};

// The whole file, checked as above; `what` names the input in messages ("marker map").
std::string read_yaml_text(const std::filesystem::path& path, std::string_view what,
                           const YamlTextOptions& options = {});

// The checks of read_yaml_text on text already read (a NUL byte, a "---x" line).
void check_yaml_text(const std::string& text, const std::filesystem::path& path,
                     std::string_view what);

}  // namespace coloc
