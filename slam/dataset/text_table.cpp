#include "slam/dataset/text_table.hpp"

#include <charconv>
#include <fstream>

#include "slam/core/error.hpp"
#include "slam/core/input_file.hpp"

namespace coloc::dataset {

std::vector<TextRow> read_text_table(const std::filesystem::path& path) {
  check_input_file(path, "list file");
  std::ifstream in(path);
  if (!in) throw Error("cannot open file", {.file = path.string()});
  std::vector<TextRow> rows;
  std::string line;
  std::int64_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    TextRow row{line_no, {}};
    std::string field;
    for (char c : line) {
      if (c == '#' && row.fields.empty() && field.empty()) break;
      if (c == ' ' || c == '\t' || c == ',' || c == '\r') {
        if (!field.empty()) row.fields.push_back(std::move(field));
        field.clear();
      } else {
        field += c;
      }
    }
    if (!field.empty()) row.fields.push_back(std::move(field));
    if (!row.fields.empty()) rows.push_back(std::move(row));
  }
  return rows;
}

double parse_double(const std::filesystem::path& path, const TextRow& row, std::size_t i) {
  if (i >= row.fields.size()) {
    throw Error("expected at least " + std::to_string(i + 1) + " columns, found " +
                    std::to_string(row.fields.size()),
                {.file = path.string(), .line = row.line});
  }
  const std::string& f = row.fields[i];
  double v = 0.0;
  const auto [ptr, ec] = std::from_chars(f.data(), f.data() + f.size(), v);
  if (ec != std::errc() || ptr != f.data() + f.size()) {
    throw Error("column " + std::to_string(i + 1) + ": '" + f + "' is not a number",
                {.file = path.string(), .line = row.line});
  }
  return v;
}

}  // namespace coloc::dataset
