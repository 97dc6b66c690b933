#include "Examples/coloc/cli_common.hpp"

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <string>

#include "Examples/coloc/verbs.hpp"

// The CLI's CMakeLists defines COLOC_SOURCE_DIR; "." keeps a stray build of a single file working.
#ifndef COLOC_SOURCE_DIR
#define COLOC_SOURCE_DIR "."
#endif

namespace coloc::cli {

CLI::Validator non_negative_seconds() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        std::size_t used = 0;
        double v = 0.0;
        try {
          v = std::stod(text, &used);
        } catch (const std::exception&) {
          return "'" + text + "' is not a number";
        }
        if (used != text.size() || !std::isfinite(v) || v < 0.0)
          return "'" + text + "' is not a finite number of seconds >= 0";
        return {};
      },
      "SECONDS>=0");
}

void print_json(const Json& document) {
  std::cout << document.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) << '\n';
}

Json json_rows(const Eigen::MatrixXd& m) {
  Json rows = Json::array();
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    Json row = Json::array();
    for (Eigen::Index c = 0; c < m.cols(); ++c)
      row.push_back(m(r, c));
    rows.push_back(std::move(row));
  }
  return rows;
}

Json json_row_major(const Eigen::MatrixXd& m) {
  Json flat = Json::array();
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    for (Eigen::Index c = 0; c < m.cols(); ++c)
      flat.push_back(m(r, c));
  }
  return flat;
}

std::filesystem::path source_dir() {
  if (const char* env = std::getenv("COLOC_SOURCE_DIR"); env != nullptr && *env != '\0') return env;
  return COLOC_SOURCE_DIR;
}

std::filesystem::path default_data_dir() {
  if (const char* env = std::getenv("COLOC_DATA"); env != nullptr && *env != '\0') return env;
  return source_dir().parent_path() / "shared" / "data";
}

}  // namespace coloc::cli
