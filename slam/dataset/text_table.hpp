#pragma once
// Line-oriented text tables as the datasets write them (whitespace- or comma-separated, '#'
// comments), with errors naming the file and line.

#include <filesystem>
#include <string>
#include <vector>

namespace coloc::dataset {

struct TextRow {
  std::int64_t line = 0;  // 1-based line number in the file
  std::vector<std::string> fields;
};

// Throws coloc::Error when the file cannot be opened.
std::vector<TextRow> read_text_table(const std::filesystem::path& path);

// Parses fields[i] as a double; throws coloc::Error naming file, line and column otherwise.
double parse_double(const std::filesystem::path& path, const TextRow& row, std::size_t i);

}  // namespace coloc::dataset
