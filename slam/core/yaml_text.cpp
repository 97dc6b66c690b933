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

void check_yaml_text(const std::string& text, const std::filesystem::path& path,
                     std::string_view what) {
  if (const auto nul = text.find('\0'); nul != std::string::npos) {
    throw Error("binary data (a NUL byte): not a YAML " + std::string(what),
                {.file = path.string(), .offset = nul});
  }
  std::int64_t line = 1;
  for (std::size_t start = 0; start < text.size(); ++line) {
    std::size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    const std::string_view row(text.data() + start, end - start);
    if (row.starts_with("---") && row.size() > 3 && row[3] != ' ' && row[3] != '\t' &&
        row[3] != '\r') {
      throw Error("a line starting with '---' that is not the YAML document marker",
                  {.file = path.string(), .line = line});
    }
    start = end + 1;
  }
}

}  // namespace coloc
