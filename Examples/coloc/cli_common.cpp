#include "Examples/coloc/cli_common.hpp"

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <string>

#include "Examples/coloc/verbs.hpp"
#include "slam/core/error.hpp"

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

std::filesystem::path data_dir() {
  if (const char* env = std::getenv("COLOC_DATA_DIR"); env != nullptr && *env != '\0') return env;
  std::error_code error;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", error);
  if (error) throw Error("cannot find this executable (/proc/self/exe): set COLOC_DATA_DIR");
  return exe.parent_path().parent_path() / "share" / "coloc";
}

std::filesystem::path data_file(const std::filesystem::path& relative) {
  const std::filesystem::path path = data_dir() / relative;
  if (!std::filesystem::exists(path))
    throw Error("coloc's data is missing (a broken install? set COLOC_DATA_DIR to its share/coloc)",
                {.file = path.string()});
  return path;
}

std::filesystem::path shipped_vocabulary() {
  return data_file("vocabulary/coloc_orb_k10_L5.cvoc");
}

std::filesystem::path recordings_dir() {
  const char* env = std::getenv("COLOC_DATA");
  return env != nullptr ? std::filesystem::path(env) : std::filesystem::path();
}

}  // namespace coloc::cli
