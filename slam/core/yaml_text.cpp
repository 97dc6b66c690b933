#include "slam/core/yaml_text.hpp"

#include <cstdint>
#include <fstream>

#include "slam/core/error.hpp"
#include "slam/core/input_file.hpp"

namespace coloc {

std::string read_yaml_text(const std::filesystem::path& path, std::string_view what,
                           const YamlTextOptions& options) {
  check_input_file(path, what);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot open " + std::string(what), {.file = path.string()});
  std::string text;
  char buffer[4096];
  while (in.read(buffer, sizeof(buffer)) || in.gcount() > 0) {
    text.append(buffer, static_cast<std::size_t>(in.gcount()));
    if (text.size() > options.max_bytes) {
      throw Error("larger than " + std::to_string(options.max_bytes >> 10) + " KiB: not a " +
                      std::string(what),
                  {.file = path.string()});
    }
  }
  check_yaml_text(text, path, what);
  return text;
}

namespace {

bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\r';
}

// Rest of a line after the document marker: blank or a comment.
bool blank_or_comment(std::string_view rest) {
  const std::size_t first = rest.find_first_not_of(" \t\r");
  return first == std::string_view::npos || rest[first] == '#';
}

}  // namespace

void check_yaml_text(const std::string& text, const std::filesystem::path& path,
                     std::string_view what) {
  if (const auto nul = text.find('\0'); nul != std::string::npos) {
    throw Error("binary data (a NUL byte): not a YAML " + std::string(what),
                {.file = path.string(), .offset = nul});
  }
  // OpenCV 4.6's top-level loop spins without advancing when, after the first document, it
  // meets a '-' that does not begin "---". It gets there when the root collection ends before
  // the end of the file: a root indented or on the marker's line ("----x", "--- a: 1", " -a"
  // then a line at column 0), a flow root ("{...}" then more), or a "..." document end. Every
  // file we read has a block collection at column 0 as its root and no "...", so those are
  // refused; a root at column 0 ends only at the end of the file. OpenCV reads a text starting
  // with '{' as JSON and one starting with "<?xml" as XML (marker maps may be either): other
  // parsers, so these rules are for YAML only.
  if (text.starts_with("{") || text.starts_with("<?xml")) return;
  const auto refuse = [&](const char* why, std::int64_t line) {
    throw Error(why, {.file = path.string(), .line = line});
  };
  bool root_seen = false;
  std::int64_t line = 1;
  for (std::size_t start = 0; start < text.size(); ++line) {
    std::size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    const std::string_view row(text.data() + start, end - start);
    start = end + 1;
    if (row.starts_with("...")) refuse("a YAML document end ('...'): not supported", line);
    if (root_seen) {
      if (row.starts_with("---")) {
        refuse("a line starting with '---' inside the document (one document per file)", line);
      }
      continue;
    }
    const std::size_t first = row.find_first_not_of(" \t\r");
    if (first == std::string_view::npos || row[first] == '#' || row[first] == '%') continue;
    if (row.substr(first).starts_with("---")) {
      if (!blank_or_comment(row.substr(first + 3))) {
        refuse("text after the YAML document marker '---' on its line", line);
      }
      continue;
    }
    if (first != 0 || is_space(row[0])) {
      refuse("the document's first key is indented: its root must start at column 0", line);
    }
    if (row[0] == '{' || row[0] == '[') {
      refuse("a flow collection ('{' or '[') as the document's root: not supported", line);
    }
    root_seen = true;
  }
}

}  // namespace coloc
