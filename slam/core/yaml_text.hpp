#pragma once
// The one way a YAML file is read before it is parsed (by OpenCV's FileStorage from memory, or
// by yaml-cpp). OpenCV 4.6's YAML reader loops forever when its root collection ends before
// the end of the file ("----x", found by scripts/fuzz_settings; " -A\nA\n-", found by
// scripts/fuzz_yaml) and asserts on some binary input; a FIFO or a device never ends. So every
// YAML reader takes its text from here: the path checked (check_input_file), the size bounded,
// and refused, each as a coloc::Error naming the file (and line): a NUL byte, a root that is
// indented, on the "---" line or a flow collection, a second "---" and a "..." line. Every
// file we read is one document whose root is a block collection at column 0.
#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>

#include "slam/core/error.hpp"

namespace coloc {

struct YamlTextOptions {
  std::size_t max_bytes = std::size_t{16} << 20;  // larger is refused: not a file of ours
};

// The whole file, checked as above; `what` names the input in messages ("marker map").
std::string read_yaml_text(const std::filesystem::path& path, std::string_view what,
                           const YamlTextOptions& options = {});

// The checks of read_yaml_text on text already read.
void check_yaml_text(const std::string& text, const std::filesystem::path& path,
                     std::string_view what);

// Runs `read` (a reader of the file at `path`) and turns anything else it throws into a
// coloc::Error naming the file: OpenCV asserts on a node of an unexpected type (isMap() in
// operator[]) and its parser lets std::length_error out on some input, yaml-cpp throws its
// conversions (scripts/fuzz_yaml found each). A coloc::Error passes unchanged.
template <class Read>
auto read_naming_file(const std::filesystem::path& path, std::string_view what, Read&& read)
    -> decltype(read()) {
  try {
    return read();
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw Error("malformed " + std::string(what) + ": " + e.what(), {.file = path.string()});
  }
}

}  // namespace coloc
